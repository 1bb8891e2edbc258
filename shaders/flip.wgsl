// FLIP (Andersson et al. 2020), the LDR pipeline of FLIP 1.2 with its
// separated filters, as three compute passes over two 8-bit sRGB images:
//   ycxcz       each pixel of both images from sRGB to YCxCz;
//   horizontal  the colour pipeline's spatial filters and the feature
//               detectors' filters along x;
//   vertical    both along y, then the colour difference (linear RGB clamped,
//               CIELab, Hunt, HyAB, compressed and remapped), the feature
//               difference (edges and points) and the per-pixel FLIP error.
// Filters clamp at the image's edge. The filter weights and the colour
// difference's maximum come from the host (src/gpu/metrics/flip.rs), computed as
// FLIP's C++ does. Locked to nv-flip by tests/it/gpu_metrics.rs.

struct Params {
    width: u32,
    height: u32,
    spatial_radius: u32,
    feature_radius: u32,
    // The largest colour difference (green to blue) after compression, and
    // the point where the remap changes slope.
    cmax: f32,
    pccmax: f32,
    pad0: f32,
    pad1: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Pixels packed as r | g << 8 | b << 16.
@group(0) @binding(1) var<storage, read_write> input_ref: array<u32>;
@group(0) @binding(2) var<storage, read_write> input_test: array<u32>;
@group(0) @binding(3) var<storage, read_write> ycxcz_ref: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> ycxcz_test: array<vec4<f32>>;
// The spatial filters' taps (Y, Cx, and Cz's two separated Gaussians), then
// the feature filter's (Gaussian, 1st and 2nd derivative, unused).
@group(0) @binding(5) var<storage, read_write> weights: array<vec4<f32>>;
// Along x: (Y, Cx, Cz by its first and by its second Gaussian).
@group(0) @binding(6) var<storage, read_write> colour_ref: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> colour_test: array<vec4<f32>>;
// Along x: (1st derivative, 2nd derivative, Gaussian, unused) of the
// normalised Y.
@group(0) @binding(8) var<storage, read_write> feature_ref: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> feature_test: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> flip_map: array<f32>;

const ILLUMINANT = vec3<f32>(0.950428545, 1.0, 1.088900371);
const INV_ILLUMINANT = vec3<f32>(1.052156925, 1.0, 0.918357670);

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        return c / 12.92;
    }
    return pow((c + 0.055) / 1.055, 2.4);
}

fn linear_rgb_to_xyz(c: vec3<f32>) -> vec3<f32> {
    let a11 = f32(10135552.0 / 24577794.0);
    let a12 = f32(8788810.0 / 24577794.0);
    let a13 = f32(4435075.0 / 24577794.0);
    let a21 = f32(2613072.0 / 12288897.0);
    let a22 = f32(8788810.0 / 12288897.0);
    let a23 = f32(887015.0 / 12288897.0);
    let a31 = f32(1425312.0 / 73733382.0);
    let a32 = f32(8788810.0 / 73733382.0);
    let a33 = f32(70074185.0 / 73733382.0);
    return vec3<f32>(
        a11 * c.x + a12 * c.y + a13 * c.z,
        a21 * c.x + a22 * c.y + a23 * c.z,
        a31 * c.x + a32 * c.y + a33 * c.z,
    );
}

fn xyz_to_linear_rgb(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        3.241003275 * c.x - 1.537398934 * c.y - 0.498615861 * c.z,
        -0.969224334 * c.x + 1.875930071 * c.y + 0.041554224 * c.z,
        0.055639423 * c.x - 0.204011202 * c.y + 1.057148933 * c.z,
    );
}

fn lab_f(t: f32) -> f32 {
    let delta = 6.0 / 29.0;
    if t > delta * delta * delta {
        return pow(t, 1.0 / 3.0);
    }
    return (1.0 / (3.0 * delta * delta)) * t + 4.0 / 29.0;
}

fn xyz_to_cielab(c: vec3<f32>) -> vec3<f32> {
    let n = c * INV_ILLUMINANT;
    let f = vec3<f32>(lab_f(n.x), lab_f(n.y), lab_f(n.z));
    return vec3<f32>(116.0 * f.y - 16.0, 500.0 * (f.x - f.y), 200.0 * (f.y - f.z));
}

fn xyz_to_ycxcz(c: vec3<f32>) -> vec3<f32> {
    let n = c * INV_ILLUMINANT;
    return vec3<f32>(116.0 * n.y - 16.0, 500.0 * (n.x - n.y), 200.0 * (n.y - n.z));
}

fn ycxcz_to_xyz(c: vec3<f32>) -> vec3<f32> {
    let y = (c.x + 16.0) / 116.0;
    let cx = c.y / 500.0;
    let cz = c.z / 200.0;
    return vec3<f32>(y + cx, y, y - cz) * ILLUMINANT;
}

// CIELab with FLIP's Hunt adjustment of the chroma (0.01 L a, 0.01 L b).
fn hunt(lab: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(lab.x, 0.01 * lab.x * lab.y, 0.01 * lab.x * lab.z);
}

fn hyab(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let d = a - b;
    return abs(d.x) + sqrt(d.y * d.y + d.z * d.z);
}

// x^y as C's powf has it at x = 0 (0 for y > 0, 1 for y = 0), where WGSL's
// pow is undefined.
fn pow0(x: f32, y: f32) -> f32 {
    if x <= 0.0 {
        return select(0.0, 1.0, y == 0.0);
    }
    return pow(x, y);
}

fn unpack_srgb(p: u32) -> vec3<f32> {
    let c = vec3<f32>(f32(p & 255u), f32((p >> 8u) & 255u), f32((p >> 16u) & 255u)) / 255.0;
    return vec3<f32>(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
}

@compute @workgroup_size(8, 8, 1)
fn ycxcz(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let i = id.y * params.width + id.x;
    ycxcz_ref[i] = vec4<f32>(xyz_to_ycxcz(linear_rgb_to_xyz(unpack_srgb(input_ref[i]))), 0.0);
    ycxcz_test[i] = vec4<f32>(xyz_to_ycxcz(linear_rgb_to_xyz(unpack_srgb(input_test[i]))), 0.0);
}

@compute @workgroup_size(8, 8, 1)
fn horizontal(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    if id.x >= w || id.y >= params.height {
        return;
    }
    let row = id.y * w;
    let last = i32(w) - 1;
    let sr = i32(params.spatial_radius);
    var c_ref = vec4<f32>(0.0);
    var c_test = vec4<f32>(0.0);
    for (var k = -sr; k <= sr; k++) {
        let xx = u32(clamp(i32(id.x) + k, 0, last));
        let wt = weights[u32(k + sr)];
        let r = ycxcz_ref[row + xx];
        let t = ycxcz_test[row + xx];
        c_ref += wt * vec4<f32>(r.x, r.y, r.z, r.z);
        c_test += wt * vec4<f32>(t.x, t.y, t.z, t.z);
    }
    let fr = i32(params.feature_radius);
    let base = u32(2 * sr + 1);
    var f_ref = vec3<f32>(0.0);
    var f_test = vec3<f32>(0.0);
    for (var k = -fr; k <= fr; k++) {
        let xx = u32(clamp(i32(id.x) + k, 0, last));
        let wt = weights[base + u32(k + fr)];
        // Y normalised to [0, 1].
        let r = ycxcz_ref[row + xx].x * (1.0 / 116.0) + 16.0 / 116.0;
        let t = ycxcz_test[row + xx].x * (1.0 / 116.0) + 16.0 / 116.0;
        f_ref += vec3<f32>(wt.y, wt.z, wt.x) * r;
        f_test += vec3<f32>(wt.y, wt.z, wt.x) * t;
    }
    colour_ref[row + id.x] = c_ref;
    colour_test[row + id.x] = c_test;
    feature_ref[row + id.x] = vec4<f32>(f_ref, 0.0);
    feature_test[row + id.x] = vec4<f32>(f_test, 0.0);
}

// The filtered YCxCz to Hunt-adjusted CIELab, through linear RGB clamped to
// [0, 1].
fn filtered_lab(c: vec4<f32>) -> vec3<f32> {
    let rgb = clamp(xyz_to_linear_rgb(ycxcz_to_xyz(vec3<f32>(c.x, c.y, c.z + c.w))), vec3<f32>(0.0), vec3<f32>(1.0));
    return hunt(xyz_to_cielab(linear_rgb_to_xyz(rgb)));
}

@compute @workgroup_size(8, 8, 1)
fn vertical(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = params.width;
    if id.x >= w || id.y >= params.height {
        return;
    }
    let last = i32(params.height) - 1;
    let sr = i32(params.spatial_radius);
    var c_ref = vec4<f32>(0.0);
    var c_test = vec4<f32>(0.0);
    for (var k = -sr; k <= sr; k++) {
        let yy = u32(clamp(i32(id.y) + k, 0, last));
        let wt = weights[u32(k + sr)];
        c_ref += wt * colour_ref[yy * w + id.x];
        c_test += wt * colour_test[yy * w + id.x];
    }
    var colour = pow0(hyab(filtered_lab(c_ref), filtered_lab(c_test)), 0.7);
    // Remapped to [0, 1]: [0, pccmax) to [0, 0.95), the rest above.
    if colour < params.pccmax {
        colour *= 0.95 / params.pccmax;
    } else {
        colour = 0.95 + ((colour - params.pccmax) / (params.cmax - params.pccmax)) * (1.0 - 0.95);
    }
    let fr = i32(params.feature_radius);
    let base = u32(2 * sr + 1);
    // (dx, ddx, dy, ddy) of each image.
    var d_ref = vec4<f32>(0.0);
    var d_test = vec4<f32>(0.0);
    for (var k = -fr; k <= fr; k++) {
        let yy = u32(clamp(i32(id.y) + k, 0, last));
        let wt = weights[base + u32(k + fr)];
        let r = feature_ref[yy * w + id.x];
        let t = feature_test[yy * w + id.x];
        d_ref += vec4<f32>(wt.x * r.x, wt.x * r.y, wt.y * r.z, wt.z * r.z);
        d_test += vec4<f32>(wt.x * t.x, wt.x * t.y, wt.y * t.z, wt.z * t.z);
    }
    let edge = abs(length(d_ref.xz) - length(d_test.xz));
    let point = abs(length(d_ref.yw) - length(d_test.yw));
    let feature = sqrt(max(edge, point) * (1.0 / sqrt(2.0)));
    flip_map[id.y * w + id.x] = pow0(colour, 1.0 - feature);
}
