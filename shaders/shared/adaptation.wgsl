// Eye adaptation's parameters for one frame (gpu::adaptation::Steps,
// written by the host each record; docs/adaptation.md), read by the
// `histogram` and `adaptation` stages. Logarithms are natural unless named
// EV (log2).
struct Steps {
    // Time constants: the fraction of the gap a frame closes, 1 - exp(-dt/tau),
    // up and down. Stops: the most a frame moves, in ln, up and down.
    up: f32,
    down: f32,
    // Stops: the fraction of the gap a frame moves within the transition,
    // up and down (f32's largest when the transition is 0).
    near_up: f32,
    near_down: f32,
    // The grey the adapted luminance maps to (auto-exposure).
    key: f32,
    // 1: take the target (the first frame, or a cut).
    reset: u32,
    // 0: time constants; 1: stops per second.
    model: u32,
    // 0: the log average of `luminance_stats`; 1: the histogram.
    metering: u32,
    // The histogram's range and the target's clamp, EV.
    min_ev: f32,
    max_ev: f32,
    // Bins per EV: 64 / (max_ev - min_ev).
    bins_per_ev: f32,
    // 0: uniform; 1: centre-weighted.
    mask: u32,
    // The fractions of the weight kept: low..high.
    low: f32,
    high: f32,
    // The compensation curve's points, (EV, stops) pairs, two a vec4.
    points: u32,
    pad: u32,
    curve: array<vec4<f32>, 4>,
}

const HISTOGRAM_BINS: u32 = 64u;

// Whether `x` is a finite number, by its exponent bits (a comparison such
// as x - x == 0 is one a driver's fast math may fold away).
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}
