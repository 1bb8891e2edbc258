// bloom_bright: which pixels feed the bloom (reference/bloom_bright.rs).
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include shared/bright.wgsl
//#include shared/extent.wgsl

// Read as a uniform: see tonemap.wgsl.
@group(0) @binding(0) var<uniform> stats: Stats;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var bright_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(src, id.xy, 0).rgb;
    textureStore(bright_out, vec2<i32>(id.xy), vec4<f32>(bright_pixel(c, stats.max_y), 1.0));
}
