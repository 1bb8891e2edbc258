// The tone curve applied to one pixel, shared by the `tonemap` stage and the
// fused kernels (fused.wgsl). The operator's module (shaders/operators/, or
// a caller's own; src/operators/mod.rs says what it defines) is included
// first; the including shader declares `config: OperatorConfig`, which is
// handed to the operator's functions (so every stage that calls them binds
// it, whether or not the operator reads it), and `resolved: Stats`.

// Fault injection only (`check --fault-gain`): 1 in every real run.
override FAULT_GAIN: f32 = 1.0;
// Eye adaptation's auto-exposure (shaders/adaptation.wgsl) of an operator
// that keys on no log average: its input times `resolved.exposure`.
override ADAPTED: bool = false;

// What the `tonemap` stage stores for HDR colour c under the resolved r:
// the operator's curve, then the fault gain (1 in every real run).
fn toned(c: vec3<f32>, r: vec4<f32>) -> vec3<f32> {
    if (ADAPTED) {
        return operator_pixel(c * resolved.exposure, r, config) * FAULT_GAIN;
    }
    return operator_pixel(c, r, config) * FAULT_GAIN;
}
