// adaptation: the luminance the eye is adapted to, carried across frames
// (reference/adaptation.rs, docs/adaptation.md). One invocation: each
// adapted value, a natural logarithm, moves toward the frame's measurement
// by the fraction of the gap `step` says (up as the scene brightens, down
// as it darkens), or takes the measurement on a reset; the statistics the
// operator reads then hold the adapted values, and `exposure` the
// auto-exposure of an operator that keys on none.
//#include shared/stats.wgsl

struct Steps {
    // 1 - exp(-dt / tau), computed on the host in f64 each frame.
    up: f32,
    down: f32,
    // The grey the adapted luminance maps to (auto-exposure).
    key: f32,
    // 1: take the measurement (the first frame, or a cut).
    reset: u32,
}

// ln of the adapted log average and weighted log average.
struct Adapted {
    log_average: f32,
    weighted_log_average: f32,
}

@group(0) @binding(0) var<storage, read_write> stats: Stats;
@group(0) @binding(1) var<storage, read_write> adapted: Adapted;
@group(0) @binding(2) var<uniform> steps: Steps;

// Which statistics the operator reads (the weighted one only where it is
// measured), and whether it keys on none (auto-exposure).
override WEIGHTED: bool = false;
override EXPOSE: bool = false;

// Whether `x` is a finite number, by its exponent bits (a comparison such
// as x - x == 0 is one a driver's fast math may fold away).
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// A non-finite measurement (a NaN or infinite pixel made the frame's log
// average one) never enters the state: the adapted value stays as it was,
// and a first frame takes ln 1 = 0 (docs/adaptation.md#bad-pixels).
fn follow(a: f32, m: f32) -> f32 {
    if (!finite(m)) {
        return select(a, 0.0, steps.reset != 0u);
    }
    if (steps.reset != 0u) {
        return m;
    }
    return a + (m - a) * select(steps.down, steps.up, m > a);
}

@compute @workgroup_size(1)
fn main() {
    let a = follow(adapted.log_average, log(stats.log_average));
    adapted.log_average = a;
    stats.log_average = exp(a);
    if (WEIGHTED) {
        let w = follow(adapted.weighted_log_average, log(stats.weighted_log_average));
        adapted.weighted_log_average = w;
        stats.weighted_log_average = exp(w);
    }
    stats.exposure = 1.0;
    if (EXPOSE) {
        stats.exposure = steps.key / stats.log_average;
    }
}
