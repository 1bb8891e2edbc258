// sphere: the view from the centre of the rotating environment sphere.
//#include shared/frame.wgsl
//#include shared/conventions.wgsl

// Samples per pixel: 1 is the plain path (no jitter), more is Halton(2,3).
override SPP: u32 = 1u;

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var env: texture_2d<f32>;
@group(0) @binding(2) var hdr_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= frame.size.x || id.y >= frame.size.y) {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < SPP; k = k + 1u) {
        let j = jitter(k, SPP);
        let d = camera_ray(f32(id.x) + 0.5 + j.x, f32(id.y) + 0.5 + j.y, frame);
        acc = acc + bilinear(env, equirect_uv(sphere_direction(frame, d)));
    }
    textureStore(hdr_out, vec2<i32>(id.xy), vec4<f32>(acc / f32(SPP), 1.0));
}
