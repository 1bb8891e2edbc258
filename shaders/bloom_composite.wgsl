// bloom_composite: C = C_tone + k·upsample(C_bloom), bilinear with texel
// centres aligned, clamped at the edges (reference/bloom_composite.rs).
//#include shared/upsample.wgsl
//#include shared/extent.wgsl

@group(0) @binding(0) var toned: texture_2d<f32>;
@group(0) @binding(1) var bloom: texture_2d<f32>;
@group(0) @binding(2) var composite_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = bloom_add(textureLoad(toned, id.xy, 0).rgb, upsample_at(bloom, id.x, id.y, dims, extent.low));
    textureStore(composite_out, vec2<i32>(id.xy), vec4<f32>(c, 1.0));
}
