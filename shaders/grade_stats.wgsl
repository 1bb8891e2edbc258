// grade_stats: mean BT.709 luminance of the frame entering the grade
// (contrast's grey), by barrier-free block sums and one ordered combine.
//#include shared/colour.wgsl
//#include shared/stats.wgsl

override BLOCK_W: u32 = 16u;
override BLOCK_H: u32 = 16u;

struct GradeMean {
    mean: f32,
}

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> sums: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> grade_mean: GradeMean;

@compute @workgroup_size(64)
fn block_sums(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(src);
    let bx_count = (dims.x + BLOCK_W - 1u) / BLOCK_W;
    let by_count = (dims.y + BLOCK_H - 1u) / BLOCK_H;
    if (id.x >= bx_count * by_count) {
        return;
    }
    let x0 = (id.x % bx_count) * BLOCK_W;
    let y0 = (id.x / bx_count) * BLOCK_H;
    var s = vec2<f32>(0.0);
    for (var y = y0; y < min(y0 + BLOCK_H, dims.y); y = y + 1u) {
        for (var x = x0; x < min(x0 + BLOCK_W, dims.x); x = x + 1u) {
            let c = textureLoad(src, vec2<u32>(x, y), 0).rgb;
            s = kahan_add(s.x, s.y, luminance_with(c, vec3<f32>(0.2126, 0.7152, 0.0722)));
        }
    }
    sums[id.x] = s;
}

@compute @workgroup_size(1)
fn finish() {
    let dims = textureDimensions(src);
    let blocks = ((dims.x + BLOCK_W - 1u) / BLOCK_W) * ((dims.y + BLOCK_H - 1u) / BLOCK_H);
    var s = vec2<f32>(0.0);
    for (var i = 0u; i < blocks; i = i + 1u) {
        s = kahan_add(s.x, s.y, sums[i].x);
        s = kahan_add(s.x, s.y, sums[i].y);
    }
    grade_mean.mean = (s.x + s.y) / (f32(dims.x) * f32(dims.y));
}
