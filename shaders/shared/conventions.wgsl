// The geometric conventions of docs/conventions.md, mirroring src/conventions.rs
// function by function.

const PI: f32 = 3.14159265358979323846;

// The (unnormalised) view direction through film point (px, py) in pixels.
fn camera_ray(px: f32, py: f32, f: FrameUniforms) -> vec3<f32> {
    let x = (2.0 * px / f32(f.size.x) - 1.0) * f.tan_half * f.aspect;
    let y = (1.0 - 2.0 * py / f32(f.size.y)) * f.tan_half;
    return vec3<f32>(x, y, -1.0);
}

// Rᵀ·d: rotating the sphere by R is rotating the view by Rᵀ.
fn sphere_direction(f: FrameUniforms, d: vec3<f32>) -> vec3<f32> {
    return f.rot0.xyz * d.x + f.rot1.xyz * d.y + f.rot2.xyz * d.z;
}

// atan of t in [0, ∞): Cephes' atanf (range reduction at tan(π/8) and
// tan(3π/8), degree-4 polynomial in t²), about 2 ULP. The built-in atan2 and
// acos may be 4096 ULP by the Vulkan spec (llvmpipe's are ~1e-4 rad), which
// moves a bilinear footprint by 2 % of a texel and shows at every hard edge.
fn atan_positive(t: f32) -> f32 {
    var x = t;
    var y = 0.0;
    if (x > 2.414213562373095) {
        y = 0.5 * PI;
        x = -1.0 / x;
    } else if (x > 0.4142135623730950) {
        y = 0.25 * PI;
        x = (x - 1.0) / (x + 1.0);
    }
    let z = x * x;
    return y + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z - 3.33329491539e-1) * z * x + x);
}

// atan2(y, x) in (−π, π] from `atan_positive`, quadrant by quadrant.
fn atan2_precise(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    var a = 0.0;
    if (ax >= ay) {
        if (ax > 0.0) {
            a = atan_positive(ay / ax);
        }
    } else {
        a = 0.5 * PI - atan_positive(ax / ay);
    }
    if (x < 0.0) {
        a = PI - a;
    }
    if (y < 0.0) {
        a = -a;
    }
    return a;
}

// acos(c) = atan2(√((1 − c)(1 + c)), c): no cancellation near ±1.
fn acos_precise(c: f32) -> f32 {
    return atan2_precise(sqrt((1.0 - c) * (1.0 + c)), c);
}

fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    // sqrt(dot) rather than length(): a driver may build length() on a
    // 12-bit reciprocal square root.
    let len = sqrt(dot(d, d));
    let u = 0.5 + atan2_precise(d.x, -d.z) / (2.0 * PI);
    let v = acos_precise(clamp(d.y / len, -1.0, 1.0)) / PI;
    return vec2<f32>(u, v);
}

// Bilinear lookup with texel centres at (k + 0.5)/W, wrapping in u and
// clamping in v: the same arithmetic as the f64 reference. The including
// shader defines `env_size()` and `env_texel(x, y)` (sphere.wgsl reads a
// storage buffer: on llvmpipe a plain load is cheaper than textureLoad).
fn bilinear(uv: vec2<f32>) -> vec3<f32> {
    let dims = vec2<i32>(env_size());
    let x = uv.x * f32(dims.x) - 0.5;
    let y = uv.y * f32(dims.y) - 0.5;
    let x0f = floor(x);
    let y0f = floor(y);
    let fx = x - x0f;
    let fy = y - y0f;
    let x0 = i32(x0f);
    let y0 = i32(y0f);
    let xa = ((x0 % dims.x) + dims.x) % dims.x;
    let xb = (((x0 + 1) % dims.x) + dims.x) % dims.x;
    let ya = clamp(y0, 0, dims.y - 1);
    let yb = clamp(y0 + 1, 0, dims.y - 1);
    let p00 = env_texel(xa, ya);
    let p10 = env_texel(xb, ya);
    let p01 = env_texel(xa, yb);
    let p11 = env_texel(xb, yb);
    let top = p00 * (1.0 - fx) + p10 * fx;
    let bottom = p01 * (1.0 - fx) + p11 * fx;
    return top * (1.0 - fy) + bottom * fy;
}

fn halton(index: u32, base: u32) -> f32 {
    var i = index;
    var f = 1.0;
    var r = 0.0;
    while (i > 0u) {
        f = f / f32(base);
        r = r + f * f32(i % base);
        i = i / base;
    }
    return r;
}

// Sample k of spp: no jitter for one sample, else Halton(2,3) from index 1.
fn jitter(k: u32, spp: u32) -> vec2<f32> {
    if (spp <= 1u) {
        return vec2<f32>(0.0, 0.0);
    }
    return vec2<f32>(halton(k + 1u, 2u) - 0.5, halton(k + 1u, 3u) - 0.5);
}

// The film point a view direction passes through (the inverse of
// `camera_ray`); the caller checks d.z < 0 first.
fn camera_project(d: vec3<f32>, f: FrameUniforms) -> vec2<f32> {
    let x = d.x / -d.z;
    let y = d.y / -d.z;
    let px = (x / (f.tan_half * f.aspect) + 1.0) * 0.5 * f32(f.size.x);
    let py = (1.0 - y / f.tan_half) * 0.5 * f32(f.size.y);
    return vec2<f32>(px, py);
}

// Where pixel (i, j)'s centre was last frame under the reprojection matrix
// with rows m0..m2, or (-1, -1) when that point was behind the camera or off
// the film (`conventions::reproject`).
fn reproject(i: u32, j: u32, m0: vec3<f32>, m1: vec3<f32>, m2: vec3<f32>, f: FrameUniforms) -> vec2<f32> {
    let d = camera_ray(f32(i) + 0.5, f32(j) + 0.5, f);
    let p = vec3<f32>(dot(m0, d), dot(m1, d), dot(m2, d));
    if (!(p.z < 0.0)) {
        return vec2<f32>(-1.0, -1.0);
    }
    let q = camera_project(p, f);
    if (q.x < 0.0 || q.x > f32(f.size.x) || q.y < 0.0 || q.y > f32(f.size.y)) {
        return vec2<f32>(-1.0, -1.0);
    }
    return q;
}
