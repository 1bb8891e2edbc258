// floor: the trivial fullscreen write the bench times every stage against.

@group(0) @binding(0) var floor_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(floor_out);
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    textureStore(floor_out, vec2<i32>(id.xy), vec4<f32>(f32(id.x) * 1e-3, f32(id.y) * 1e-3, 0.5, 1.0));
}
