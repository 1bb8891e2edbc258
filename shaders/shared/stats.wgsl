// Statistics and the operator's resolved values, written by luminance_stats
// and tonemap's resolve step. Mirrors `gpu::GpuStats`.
struct Stats {
    log_average: f32,
    weighted_log_average: f32,
    min_y: f32,
    max_y: f32,
    weight_sum: f32,
    // The scale of the operator's input: key / the adapted luminance, set
    // by `adaptation` for an operator that keys on no log average and read
    // by `tonemap` under ADAPTED; nothing reads it otherwise.
    exposure: f32,
    // The operator's resolved values (its `operator_resolve`, run by
    // tonemap's resolve step), at offset 32: vec4 alignment.
    tone: vec4<f32>,
}

// A partial reduction: min, max and three compensated (Kahan) sums.
struct Partial {
    min_y: f32,
    max_y: f32,
    log_sum: f32,
    log_c: f32,
    wlog_sum: f32,
    wlog_c: f32,
    w_sum: f32,
    w_c: f32,
}

fn empty_partial() -> Partial {
    return Partial(3.4028235e38, -3.4028235e38, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
}

// Neumaier's compensated addition of x into (sum, c); returns the pair.
fn kahan_add(sum: f32, c: f32, x: f32) -> vec2<f32> {
    let t = sum + x;
    var nc = c;
    if (abs(sum) >= abs(x)) {
        nc = nc + ((sum - t) + x);
    } else {
        nc = nc + ((x - t) + sum);
    }
    return vec2<f32>(t, nc);
}

fn merge_partial(a: Partial, b: Partial) -> Partial {
    var r = a;
    r.min_y = min(a.min_y, b.min_y);
    r.max_y = max(a.max_y, b.max_y);
    var s = kahan_add(a.log_sum, a.log_c, b.log_sum);
    s = kahan_add(s.x, s.y, b.log_c);
    r.log_sum = s.x;
    r.log_c = s.y;
    s = kahan_add(a.wlog_sum, a.wlog_c, b.wlog_sum);
    s = kahan_add(s.x, s.y, b.wlog_c);
    r.wlog_sum = s.x;
    r.wlog_c = s.y;
    s = kahan_add(a.w_sum, a.w_c, b.w_sum);
    s = kahan_add(s.x, s.y, b.w_c);
    r.w_sum = s.x;
    r.w_c = s.y;
    return r;
}
