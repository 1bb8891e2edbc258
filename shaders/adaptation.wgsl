// adaptation: the luminance the eye is adapted to, carried across frames
// (reference/adaptation.rs, docs/adaptation.md). One invocation: the frame
// is metered (the log average `luminance_stats` measured, or the mean EV of
// the histogram's kept weight, whose bins it then clears for the next
// frame), the measurement less the compensation and clamped to the EV
// range is the target, and each adapted value, a natural logarithm, moves
// toward it by the model's rule, or takes it on a reset; the statistics the
// operator reads then hold the adapted values, and `exposure` the
// auto-exposure of an operator that keys on none.
//#include shared/stats.wgsl
//#include shared/adaptation.wgsl

// ln of the adapted log average, weighted log average and largest
// luminance (the white point's, once a frame had a finite one: has_max).
struct Adapted {
    log_average: f32,
    weighted_log_average: f32,
    max_y: f32,
    has_max: u32,
}

@group(0) @binding(0) var<storage, read_write> stats: Stats;
@group(0) @binding(1) var<storage, read_write> adapted: Adapted;
@group(0) @binding(2) var<uniform> steps: Steps;
@group(0) @binding(3) var<storage, read_write> bins: array<u32, HISTOGRAM_BINS>;

// Which statistics the operator reads (the weighted one only where it is
// measured), and whether it keys on none (auto-exposure).
override WEIGHTED: bool = false;
override EXPOSE: bool = false;
// Whether the white point the operator reads from the largest luminance
// follows it (`adapt_white`, an operator that reads the max).
override WHITE: bool = false;

const LN2: f32 = 0.6931471805599453;

// Stops of compensation at metered `ev`: the curve's points joined by
// lines, flat beyond the first and last.
fn compensation(ev: f32) -> f32 {
    if (steps.points == 0u) {
        return 0.0;
    }
    var x0 = steps.curve[0].x;
    var y0 = steps.curve[0].y;
    if (ev <= x0) {
        return y0;
    }
    for (var i = 1u; i < steps.points; i = i + 1u) {
        let q = steps.curve[i / 2u];
        let x1 = select(q.x, q.z, (i & 1u) == 1u);
        let y1 = select(q.y, q.w, (i & 1u) == 1u);
        if (ev < x1) {
            return y0 + (y1 - y0) * (ev - x0) / (x1 - x0);
        }
        x0 = x1;
        y0 = y1;
    }
    return y0;
}

// The target of a measurement `m` (ln): less the compensation, clamped.
fn target_of(m: f32) -> f32 {
    let t = m - compensation(m / LN2) * LN2;
    return clamp(t, steps.min_ev * LN2, steps.max_ev * LN2);
}

// A non-finite measurement (a NaN or infinite pixel made the frame's log
// average one; the histogram kept no weight) never enters the state: the
// adapted value stays as it was, and a first frame takes ln 1, clamped
// (docs/adaptation.md#bad-pixels).
fn follow(a: f32, m: f32, ok: bool) -> f32 {
    if (!ok || !finite(m)) {
        return select(a, target_of(0.0), steps.reset != 0u);
    }
    let t = target_of(m);
    if (steps.reset != 0u) {
        return t;
    }
    return toward(a, t);
}

// The model's move from `a` toward `t`, both ln.
fn toward(a: f32, t: f32) -> f32 {
    let gap = t - a;
    let up = gap > 0.0;
    if (steps.model == 0u) {
        return a + gap * select(steps.down, steps.up, up);
    }
    let most = select(steps.down, steps.up, up);
    let near = select(steps.near_down, steps.near_up, up);
    let g = abs(gap);
    return a + sign(gap) * min(min(g, most), g * near);
}

// The histogram's metered EV (the mean bin centre of the weight between
// the low and high fractions), and whether any weight was kept; the bins
// are cleared for the next frame.
fn histogram_ev() -> vec2<f32> {
    var total = 0u;
    for (var i = 0u; i < HISTOGRAM_BINS; i = i + 1u) {
        total = total + bins[i];
    }
    let lo = steps.low * f32(total);
    let hi = steps.high * f32(total);
    let width = 1.0 / steps.bins_per_ev;
    var below = 0u;
    var sum = 0.0;
    var kept = 0.0;
    for (var i = 0u; i < HISTOGRAM_BINS; i = i + 1u) {
        let upto = below + bins[i];
        let k = clamp(f32(upto), lo, hi) - clamp(f32(below), lo, hi);
        sum = sum + k * (steps.min_ev + (f32(i) + 0.5) * width);
        kept = kept + k;
        below = upto;
        bins[i] = 0u;
    }
    return vec2<f32>(sum / max(kept, 1e-30), select(0.0, 1.0, kept > 0.0));
}

@compute @workgroup_size(1)
fn main() {
    var m = log(stats.log_average);
    var mw = log(stats.weighted_log_average);
    var ok = true;
    if (steps.metering == 1u) {
        let h = histogram_ev();
        m = h.x * LN2;
        mw = m;
        ok = h.y > 0.0;
    }
    let a = follow(adapted.log_average, m, ok);
    adapted.log_average = a;
    stats.log_average = exp(a);
    if (WEIGHTED) {
        let w = follow(adapted.weighted_log_average, mw, ok);
        adapted.weighted_log_average = w;
        stats.weighted_log_average = exp(w);
    }
    if (WHITE) {
        // The white point: unclamped, uncompensated; a non-finite largest
        // luminance leaves it (or, before any, the frame its own).
        let m = log(stats.max_y);
        let fresh = steps.reset != 0u || adapted.has_max == 0u;
        if (finite(m)) {
            var w = m;
            if (!fresh) {
                w = toward(adapted.max_y, m);
            }
            adapted.max_y = w;
            adapted.has_max = 1u;
            stats.max_y = exp(w);
        } else if (!fresh) {
            stats.max_y = exp(adapted.max_y);
        } else {
            adapted.has_max = 0u;
        }
    }
    stats.exposure = 1.0;
    if (EXPOSE) {
        stats.exposure = steps.key / stats.log_average;
    }
}
