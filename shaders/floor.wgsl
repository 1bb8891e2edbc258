// floor: the trivial fullscreen passes the bench times every stage against,
// inside every measured frame's submission.
//   main:    one textureStore per pixel (the write-only floor);
//   main_rw: one textureLoad and one textureStore per pixel (the read-write
//            floor: the honest minimum for a stage that reads a frame and
//            writes one).

@group(0) @binding(0) var floor_out: texture_storage_2d<HDR_FORMAT, write>;
@group(0) @binding(1) var floor_in: texture_2d<f32>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(floor_out);
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    textureStore(floor_out, vec2<i32>(id.xy), vec4<f32>(f32(id.x) * 1e-3, f32(id.y) * 1e-3, 0.5, 1.0));
}

@compute @workgroup_size(64, 1)
fn main_rw(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(floor_out);
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(floor_in, vec2<i32>(id.xy), 0);
    textureStore(floor_out, vec2<i32>(id.xy), c * 0.5 + vec4<f32>(0.25));
}
