// grade: the image-processing lecture's (docs/bibliography.md) brightness,
// contrast (mix with the mean-luminance grey) and saturation (mix with the
// pixel's luminance), as reference/grade.rs.
//#include shared/colour.wgsl
//#include shared/extent.wgsl

override BRIGHTNESS: f32 = 1.0;
override CONTRAST: f32 = 1.0;
override SATURATION: f32 = 1.0;

struct GradeMean {
    mean: f32,
}

// Written by grade_stats, read here as a uniform (see tonemap.wgsl).
@group(0) @binding(0) var<uniform> grade_mean: GradeMean;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var graded_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let v = grade_pixel(textureLoad(src, id.xy, 0).rgb, grade_mean.mean);
    textureStore(graded_out, vec2<i32>(id.xy), vec4<f32>(v, 1.0));
}

// One pixel c of a frame whose mean luminance is `mean`.
fn grade_pixel(c: vec3<f32>, mean: f32) -> vec3<f32> {
    let grey = BRIGHTNESS * mean;
    var v = c * BRIGHTNESS;
    v = grey + (v - grey) * CONTRAST;
    let y = luminance_with(v, vec3<f32>(0.2125, 0.7154, 0.0721));
    v = y + (v - y) * SATURATION;
    return v;
}
