// taa: the jittered frame resolved against its reprojected, clipped history
// and sharpened (the TAA thesis §3.6, docs/bibliography.md), mirroring
// src/reference/taa.rs step by step.
//#include shared/frame.wgsl
//#include shared/conventions.wgsl
//#include shared/colour.wgsl

// The history's weight range (scene `[taa]` feedback_min / feedback_max).
override FEEDBACK_MIN: f32 = 0.88;
override FEEDBACK_MAX: f32 = 0.97;
// Sharpen strength s of the TAA thesis's kernel [0 −1 0; −1 5 −1; 0 −1 0].
override SHARPEN: f32 = 0.25;
// Fault injection (`check --taa-fault no-clip`): blend the unclipped history.
override NO_CLIP: bool = false;
// `history_filter = "catmull_rom"`: 4×4 Catmull-Rom instead of bilinear.
override CATMULL_ROM: bool = false;
// `feedback = "motion"`: the current frame's weight from the motion and the
// pixel's frame count, instead of the luminance difference.
override MOTION_FEEDBACK: bool = false;
override CURRENT_MIN: f32 = 0.0625;
override CURRENT_MOVING: f32 = 0.2;
override CURRENT_PER_PX: f32 = 0.1;
override CURRENT_MAX: f32 = 0.35;
override STATIC_PX: f32 = 0.001;
// `variant = "variance"`: the box's half-width in standard deviations.
override VARIANCE_GAMMA: f32 = 1.0;
// `blend = "tonemapped"`: each colour also weighted by 1 / (1 + Y).
override TONEMAPPED_BLEND: bool = false;
// reference::taa::CONFIDENCE_CAP.
const CONFIDENCE_CAP: f32 = 1024.0;

struct TaaUniforms {
    // Rows of the reprojection matrix R(n−1)·R(n)ᵀ (xyz).
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    // 0 on a reset: the frame has no history.
    has_history: u32,
    _pad: u32,
    // The `_motion` entries: what turns a motion vector into the offset, in
    // pixels, to where the pixel's centre was in the previous frame.
    motion_scale: vec2<f32>,
}

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var<uniform> taa: TaaUniforms;
@group(0) @binding(2) var current: texture_2d<f32>;
@group(0) @binding(3) var history_in: texture_2d<f32>;
@group(0) @binding(4) var amount: texture_2d<f32>;
@group(0) @binding(5) var history_out: texture_storage_2d<HDR_FORMAT, write>;
// The stage output when the sharpen is off (SHARPEN = 0): the blend itself.
@group(0) @binding(6) var taa_out: texture_storage_2d<HDR_FORMAT, write>;
// The sharpen entry's input (this frame's blend) and output.
@group(0) @binding(7) var blend_in: texture_2d<f32>;
// The `_hardware` entries' history filter: the texture unit's linear
// filter, clamping to the edge (`--env-filter hardware`).
@group(0) @binding(8) var history_sampler: sampler;
// The `_motion` entries' history point: an application's motion vectors
// (xy of each texel), in place of the camera's reprojection.
@group(0) @binding(9) var motion: texture_2d<f32>;

const BT709 = vec3<f32>(0.2126, 0.7152, 0.0722);

// conventions.wgsl's `bilinear` reads the environment through these; `taa`
// reads no environment and never calls it.
fn env_size() -> vec2<u32> {
    return vec2<u32>(1u, 1u);
}
fn env_texel(x: i32, y: i32) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn load_clamped(t: texture_2d<f32>, x: i32, y: i32) -> vec3<f32> {
    let dims = vec2<i32>(textureDimensions(t));
    return textureLoad(t, vec2<i32>(clamp(x, 0, dims.x - 1), clamp(y, 0, dims.y - 1)), 0).rgb;
}

fn amount_at(x: i32, y: i32) -> f32 {
    let dims = vec2<i32>(textureDimensions(amount));
    return textureLoad(amount, vec2<i32>(clamp(x, 0, dims.x - 1), clamp(y, 0, dims.y - 1)), 0).r;
}

// Catmull-Rom weights of the four taps around the fraction t.
fn catmull_rom_weights(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    );
}

// One row of the 4×4 footprint, weighted along x.
fn catmull_rom_row(x0: i32, y: i32, wx: vec4<f32>) -> vec3<f32> {
    return wx.x * load_clamped(history_in, x0 - 1, y) + wx.y * load_clamped(history_in, x0, y)
        + wx.z * load_clamped(history_in, x0 + 1, y) + wx.w * load_clamped(history_in, x0 + 2, y);
}

// The history at film point q over 4×4 texels, clamped at 0.
fn history_catmull_rom(q: vec2<f32>) -> vec3<f32> {
    let x = q.x - 0.5;
    let y = q.y - 0.5;
    let x0f = floor(x);
    let y0f = floor(y);
    let wx = catmull_rom_weights(x - x0f);
    let wy = catmull_rom_weights(y - y0f);
    let x0 = i32(x0f);
    let y0 = i32(y0f);
    let out = wy.x * catmull_rom_row(x0, y0 - 1, wx) + wy.y * catmull_rom_row(x0, y0, wx)
        + wy.z * catmull_rom_row(x0, y0 + 1, wx) + wy.w * catmull_rom_row(x0, y0 + 2, wx);
    return max(out, vec3<f32>(0.0));
}

// The history at film point q with the scene's filter.
fn history_at(q: vec2<f32>) -> vec3<f32> {
    if (CATMULL_ROM) {
        return history_catmull_rom(q);
    }
    return history_bilinear(q);
}

// The history at film point q, bilinear over texel centres, border clamped.
fn history_bilinear(q: vec2<f32>) -> vec3<f32> {
    let x = q.x - 0.5;
    let y = q.y - 0.5;
    let x0f = floor(x);
    let y0f = floor(y);
    let fx = x - x0f;
    let fy = y - y0f;
    let x0 = i32(x0f);
    let y0 = i32(y0f);
    let p00 = load_clamped(history_in, x0, y0);
    let p10 = load_clamped(history_in, x0 + 1, y0);
    let p01 = load_clamped(history_in, x0, y0 + 1);
    let p11 = load_clamped(history_in, x0 + 1, y0 + 1);
    let top = p00 * (1.0 - fx) + p10 * fx;
    let bottom = p01 * (1.0 - fx) + p11 * fx;
    return top * (1.0 - fy) + bottom * fy;
}

// The history at film point q through the texture unit's bilinear filter:
// one tap for the bilinear history; for Catmull-Rom, each axis's two middle
// taps (both weights positive) as one bilinear tap between them, so 3×3
// taps instead of 4×4 loads. Clamping to the edge repeats the border texel
// as `load_clamped` does. Exact but for the filter's quantised sub-texel
// weights (docs/conventions.md#bilinear-filtering).
fn history_hardware(q: vec2<f32>) -> vec3<f32> {
    let inv = 1.0 / vec2<f32>(textureDimensions(history_in));
    if (!CATMULL_ROM) {
        return textureSampleLevel(history_in, history_sampler, q * inv, 0.0).rgb;
    }
    let x = q - 0.5;
    let base = floor(x);
    let wx = catmull_rom_weights(x.x - base.x);
    let wy = catmull_rom_weights(x.y - base.y);
    // Texel centres of the outer taps and the middle pair's weighted point.
    let middle = vec2<f32>(wx.y + wx.z, wy.y + wy.z);
    let c0 = (base - 0.5) * inv;
    let c1 = (base + 0.5 + vec2<f32>(wx.z, wy.z) / middle) * inv;
    let c2 = (base + 2.5) * inv;
    let xs = vec3<f32>(c0.x, c1.x, c2.x);
    let ws = vec3<f32>(wx.x, middle.x, wx.w);
    let ys = vec3<f32>(c0.y, c1.y, c2.y);
    let hs = vec3<f32>(wy.x, middle.y, wy.w);
    var out = vec3<f32>(0.0);
    for (var j = 0; j < 3; j = j + 1) {
        var row = vec3<f32>(0.0);
        for (var i = 0; i < 3; i = i + 1) {
            row = row + ws[i] * textureSampleLevel(history_in, history_sampler, vec2<f32>(xs[i], ys[j]), 0.0).rgb;
        }
        out = out + hs[j] * row;
    }
    return max(out, vec3<f32>(0.0));
}

// Where pixel id's history is on the film, (−1, −1) for none (a reset, or
// reprojected off the film).
fn history_point(id: vec2<u32>) -> vec2<f32> {
    if (taa.has_history == 0u) {
        return vec2<f32>(-1.0);
    }
    return reproject(id.x, id.y, taa.m0.xyz, taa.m1.xyz, taa.m2.xyz, frame);
}

// reference::taa::Reprojection::Motion: pixel id's centre moved by its
// scaled motion vector, (−1, −1) for none (a reset, a point off the film,
// or a vector that is not a number).
fn motion_point(id: vec2<u32>) -> vec2<f32> {
    if (taa.has_history == 0u) {
        return vec2<f32>(-1.0);
    }
    let v = textureLoad(motion, vec2<i32>(id), 0).xy;
    let q = vec2<f32>(id) + vec2<f32>(0.5) + taa.motion_scale * v;
    let size = vec2<f32>(frame.size);
    if (!(q.x >= 0.0 && q.x <= size.x && q.y >= 0.0 && q.y <= size.y)) {
        return vec2<f32>(-1.0);
    }
    return q;
}

// The cross (+) and 3×3 neighbourhoods' min and max.
struct Neighbourhood {
    lo_cross: vec3<f32>,
    hi_cross: vec3<f32>,
    lo_all: vec3<f32>,
    hi_all: vec3<f32>,
}

fn neighbourhood(x: i32, y: i32) -> Neighbourhood {
    var n: Neighbourhood;
    let c = load_clamped(current, x, y);
    let l = load_clamped(current, x - 1, y);
    let r = load_clamped(current, x + 1, y);
    let u = load_clamped(current, x, y - 1);
    let d = load_clamped(current, x, y + 1);
    n.lo_cross = min(min(min(c, l), min(r, u)), d);
    n.hi_cross = max(max(max(c, l), max(r, u)), d);
    let a = load_clamped(current, x - 1, y - 1);
    let b = load_clamped(current, x + 1, y - 1);
    let e = load_clamped(current, x - 1, y + 1);
    let f = load_clamped(current, x + 1, y + 1);
    n.lo_all = min(n.lo_cross, min(min(a, b), min(e, f)));
    n.hi_all = max(n.hi_cross, max(max(a, b), max(e, f)));
    return n;
}

// `clip_to_box` of the reference: toward the box centre, onto its surface.
fn clip_to_box(h: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec3<f32> {
    let centre = 0.5 * (lo + hi);
    let extent = 0.5 * (hi - lo);
    let v = h - centre;
    var reach = 0.0;
    var flat_miss = false;
    for (var k = 0; k < 3; k = k + 1) {
        if (extent[k] > 0.0) {
            reach = max(reach, abs(v[k]) / extent[k]);
        } else if (v[k] != 0.0) {
            flat_miss = true;
        }
    }
    if (flat_miss) {
        return centre;
    }
    if (reach <= 1.0) {
        return h;
    }
    return centre + v / reach;
}

fn feedback(c: vec3<f32>, h: vec3<f32>) -> f32 {
    let yc = luminance_with(c, BT709);
    let yh = luminance_with(h, BT709);
    let top = max(yc, yh);
    var d = 0.0;
    if (top >= SMALLEST_NORMAL) {
        d = min(abs(yc - yh) / top, 1.0);
    }
    let w = (1.0 - d) * (1.0 - d);
    return FEEDBACK_MIN + (FEEDBACK_MAX - FEEDBACK_MIN) * w;
}

// The frame count of the history texel under film point q, border clamped.
fn confidence_at(q: vec2<f32>) -> f32 {
    let dims = vec2<i32>(textureDimensions(history_in));
    let t = clamp(vec2<i32>(floor(q)), vec2<i32>(0), dims - 1);
    return textureLoad(history_in, t, 0).a;
}

// reference::taa::motion_weight: the current frame's weight.
fn motion_weight(frames: f32, motion_px: f32) -> f32 {
    var w = CURRENT_MIN;
    if (motion_px >= STATIC_PX) {
        w = min(CURRENT_MOVING + CURRENT_PER_PX * motion_px, CURRENT_MAX);
    }
    return max(w, 1.0 / frames);
}

// reference::taa::blend: c and h with the history weighing w; a static
// pixel is blended linearly.
fn blend(c: vec3<f32>, h: vec3<f32>, w: f32, moving: bool) -> vec3<f32> {
    if (TONEMAPPED_BLEND && moving) {
        let wc = (1.0 - w) / (1.0 + luminance_with(c, BT709));
        let wh = w / (1.0 + luminance_with(h, BT709));
        return c + (h - c) * (wh / (wc + wh));
    }
    return c + (h - c) * w;
}

fn to_ycocg(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        0.25 * c.x + 0.5 * c.y + 0.25 * c.z,
        0.5 * c.x - 0.5 * c.z,
        -0.25 * c.x + 0.5 * c.y - 0.25 * c.z,
    );
}

fn from_ycocg(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z);
}

// How the history is clipped: to a box, or (VARIANCE) by the moments.
struct Clip {
    lo: vec3<f32>,
    hi: vec3<f32>,
    // YCoCg sums of the 3×3 neighbourhood and of their squares (VARIANCE).
    sum: vec3<f32>,
    sum_sq: vec3<f32>,
    variance: bool,
}

// reference::taa::clip_variance, from the moments.
fn clip_variance(h: vec3<f32>, sum: vec3<f32>, sum_sq: vec3<f32>) -> vec3<f32> {
    let mean = sum / 9.0;
    let sigma = sqrt(max(sum_sq / 9.0 - mean * mean, vec3<f32>(0.0)));
    let clipped = clip_to_box(to_ycocg(h), mean - VARIANCE_GAMMA * sigma, mean + VARIANCE_GAMMA * sigma);
    return max(from_ycocg(clipped), vec3<f32>(0.0));
}

// The blend of pixel id given how to clip and its history `h`, read at
// `q` (from `history_point`); writes the new history, its frame count in
// alpha (and the output when there is no sharpen pass).
fn finish(id: vec2<u32>, clip: Clip, q: vec2<f32>, history: vec3<f32>) {
    let c = textureLoad(current, vec2<i32>(id), 0).rgb;
    var out = c;
    var frames = 1.0;
    if (q.x >= 0.0) {
        var h = history;
        frames = min(confidence_at(q) + 1.0, CONFIDENCE_CAP);
        if (!NO_CLIP) {
            if (clip.variance) {
                h = clip_variance(h, clip.sum, clip.sum_sq);
            } else {
                h = clip_to_box(h, clip.lo, clip.hi);
            }
        }
        let d = q - (vec2<f32>(id) + vec2<f32>(0.5));
        let motion = sqrt(dot(d, d));
        var w: f32;
        if (MOTION_FEEDBACK) {
            w = 1.0 - motion_weight(frames, motion);
        } else {
            w = feedback(c, h);
        }
        out = blend(c, h, w, motion >= STATIC_PX);
    }
    textureStore(history_out, vec2<i32>(id), vec4<f32>(out, frames));
    if (SHARPEN == 0.0) {
        textureStore(taa_out, vec2<i32>(id), vec4<f32>(out, 1.0));
    }
}

fn box_clip(lo: vec3<f32>, hi: vec3<f32>) -> Clip {
    var clip: Clip;
    clip.lo = lo;
    clip.hi = hi;
    clip.variance = false;
    return clip;
}

// `taa = "clip"`: the two neighbourhoods' bounds averaged.
fn clip_averaged(id: vec2<u32>) -> Clip {
    let n = neighbourhood(i32(id.x), i32(id.y));
    return box_clip(0.5 * (n.lo_cross + n.lo_all), 0.5 * (n.hi_cross + n.hi_all));
}

// `taa = "variance"`: the 3×3 neighbourhood's YCoCg moments.
fn clip_moments(id: vec2<u32>) -> Clip {
    var clip: Clip;
    clip.variance = true;
    clip.sum = vec3<f32>(0.0);
    clip.sum_sq = vec3<f32>(0.0);
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let q = to_ycocg(load_clamped(current, i32(id.x) + dx, i32(id.y) + dy));
            clip.sum = clip.sum + q;
            clip.sum_sq = clip.sum_sq + q * q;
        }
    }
    return clip;
}

// `taa = "edge_aware"`: blended by the aliasing amount, shrunk toward the
// current colour where there is no edge (the TAA thesis, eqs. 4.12–4.16).
fn clip_edge_aware(id: vec2<u32>) -> Clip {
    let x = i32(id.x);
    let y = i32(id.y);
    let centre = amount_at(x, y);
    let cross = centre + amount_at(x - 1, y) + amount_at(x + 1, y) + amount_at(x, y - 1) + amount_at(x, y + 1);
    let all = cross + amount_at(x - 1, y - 1) + amount_at(x + 1, y - 1) + amount_at(x - 1, y + 1) + amount_at(x + 1, y + 1);
    let a = clamp(cross / 5.0 + (all / 9.0 - cross / 5.0) * clamp(centre, 0.0, 1.0), 0.0, 1.0);
    let n = neighbourhood(x, y);
    let c = textureLoad(current, vec2<i32>(id), 0).rgb;
    let lo = n.lo_cross + (n.lo_all - n.lo_cross) * a;
    let hi = n.hi_cross + (n.hi_all - n.hi_cross) * a;
    return box_clip(c + (lo - c) * a, c + (hi - c) * a);
}

fn outside(id: vec3<u32>) -> bool {
    return id.x >= frame.size.x || id.y >= frame.size.y;
}

// One entry per clip, reading the history with loads (the reference's
// arithmetic) or, `_hardware`, through the texture unit's filter.
@compute @workgroup_size(64, 1)
fn resolve_clip(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_averaged(id.xy), q, history_at(q));
}

@compute @workgroup_size(64, 1)
fn resolve_clip_hardware(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_averaged(id.xy), q, history_hardware(q));
}

@compute @workgroup_size(64, 1)
fn resolve_variance(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_moments(id.xy), q, history_at(q));
}

@compute @workgroup_size(64, 1)
fn resolve_variance_hardware(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_moments(id.xy), q, history_hardware(q));
}

@compute @workgroup_size(64, 1)
fn resolve_edge_aware(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_edge_aware(id.xy), q, history_at(q));
}

@compute @workgroup_size(64, 1)
fn resolve_edge_aware_hardware(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = history_point(id.xy);
    finish(id.xy, clip_edge_aware(id.xy), q, history_hardware(q));
}

// The `_motion` entries: the history where the application's motion
// vectors say (the tone mapper embedded in an application), read with loads.
@compute @workgroup_size(64, 1)
fn resolve_clip_motion(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = motion_point(id.xy);
    finish(id.xy, clip_averaged(id.xy), q, history_at(q));
}

@compute @workgroup_size(64, 1)
fn resolve_variance_motion(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = motion_point(id.xy);
    finish(id.xy, clip_moments(id.xy), q, history_at(q));
}

@compute @workgroup_size(64, 1)
fn resolve_edge_aware_motion(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let q = motion_point(id.xy);
    finish(id.xy, clip_edge_aware(id.xy), q, history_at(q));
}

// The sharpen: b + s·(4b − N − S − E − W), limited to the cross
// neighbourhood's range (reference::taa::sharpen says why).
@compute @workgroup_size(64, 1)
fn sharpen(@builtin(global_invocation_id) id: vec3<u32>) {
    if (outside(id)) {
        return;
    }
    let x = i32(id.x);
    let y = i32(id.y);
    let b = load_clamped(blend_in, x, y);
    let n = load_clamped(blend_in, x, y - 1);
    let s = load_clamped(blend_in, x, y + 1);
    let e = load_clamped(blend_in, x + 1, y);
    let w = load_clamped(blend_in, x - 1, y);
    let lap = 4.0 * b - n - s - e - w;
    let lo = min(min(min(b, n), min(s, e)), w);
    let hi = max(max(max(b, n), max(s, e)), w);
    textureStore(taa_out, vec2<i32>(id.xy), vec4<f32>(clamp(b + SHARPEN * lap, lo, hi), 1.0));
}
