// bloom_bright: which pixels feed the bloom (reference/bloom_bright.rs).
//#include shared/colour.wgsl
//#include shared/stats.wgsl

// 0 = seed 001 (C·Y/Lmax where Y > T, on HDR), 1 = seed 004 (C where Y > T).
override PASS: u32 = 0u;
override THRESHOLD: f32 = 1.0;
override LUM_R: f32 = 0.2126;
override LUM_G: f32 = 0.7152;
override LUM_B: f32 = 0.0722;

// Read as a uniform: see tonemap.wgsl.
@group(0) @binding(0) var<uniform> stats: Stats;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var bright_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(src);
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(src, id.xy, 0).rgb;
    let y = luminance_with(c, vec3<f32>(LUM_R, LUM_G, LUM_B));
    var out = vec3<f32>(0.0);
    if (y > THRESHOLD) {
        if (PASS == 0u) {
            var inv_max = 0.0;
            if (stats.max_y > 0.0 && stats.max_y < 3.0e38) {
                inv_max = 1.0 / stats.max_y;
            }
            out = c * (y * inv_max);
        } else {
            out = c;
        }
    }
    textureStore(bright_out, vec2<i32>(id.xy), vec4<f32>(out, 1.0));
}
