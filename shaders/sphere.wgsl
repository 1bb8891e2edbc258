// sphere: the view from the centre of the rotating environment sphere.
//#include shared/frame.wgsl
//#include shared/conventions.wgsl

// Samples per pixel: 1 is the plain path (no jitter), more is Halton(2,3).
override SPP: u32 = 1u;

// The environment's width and height.
override ENV_W: u32 = 1u;
override ENV_H: u32 = 1u;

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
// Row-major RGBA texels of the environment map.
@group(0) @binding(1) var<storage, read> env: array<vec4<f32>>;
@group(0) @binding(2) var hdr_out: texture_storage_2d<HDR_FORMAT, write>;

fn env_size() -> vec2<u32> {
    return vec2<u32>(ENV_W, ENV_H);
}

fn env_texel(x: i32, y: i32) -> vec3<f32> {
    return env[u32(y) * ENV_W + u32(x)].rgb;
}

// The hardware-filtered variant (`main_hardware`): the same map as a texture
// and a linear sampler, repeating in u and clamping in v. Faster where the
// sampler is fixed-function; its weights are quantised (often to 8 bits),
// so it is an option to measure, not the reference path.
@group(0) @binding(3) var env_texture: texture_2d<f32>;
@group(0) @binding(4) var env_sampler: sampler;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= frame.size.x || id.y >= frame.size.y) {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < SPP; k = k + 1u) {
        let j = jitter(k, SPP) + frame.jitter;
        let d = camera_ray(f32(id.x) + 0.5 + j.x, f32(id.y) + 0.5 + j.y, frame);
        acc = acc + bilinear(equirect_uv(sphere_direction(frame, d)));
    }
    textureStore(hdr_out, vec2<i32>(id.xy), vec4<f32>(acc / f32(SPP) * frame.light, 1.0));
}

@compute @workgroup_size(64, 1)
fn main_hardware(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= frame.size.x || id.y >= frame.size.y) {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < SPP; k = k + 1u) {
        let j = jitter(k, SPP) + frame.jitter;
        let d = camera_ray(f32(id.x) + 0.5 + j.x, f32(id.y) + 0.5 + j.y, frame);
        let uv = equirect_uv(sphere_direction(frame, d));
        acc = acc + textureSampleLevel(env_texture, env_sampler, uv, 0.0).rgb;
    }
    textureStore(hdr_out, vec2<i32>(id.xy), vec4<f32>(acc / f32(SPP) * frame.light, 1.0));
}
