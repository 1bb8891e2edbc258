// tonemap: the operator's resolve step (one invocation: the statistics into
// the curve's values), then its curve on every pixel. The operator's module
// (shaders/operators/, or a caller's own) is included in place of
// `//#include operator` (src/gpu/shaders.rs).
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include operator
//#include shared/tone.wgsl
//#include shared/extent.wgsl

@group(0) @binding(0) var<uniform> config: OperatorConfig;
// `resolve` writes the statistics buffer; `main` reads the same buffer as a
// uniform (binding 4), which llvmpipe loads once per SIMD batch instead of
// lane by lane.
@group(0) @binding(1) var<storage, read_write> stats: Stats;
@group(0) @binding(2) var hdr: texture_2d<f32>;
@group(0) @binding(3) var toned_out: texture_storage_2d<HDR_FORMAT, write>;
@group(0) @binding(4) var<uniform> resolved: Stats;

@compute @workgroup_size(1)
fn resolve() {
    stats.tone = operator_resolve(stats, config);
}

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(hdr, id.xy, 0).rgb;
    textureStore(toned_out, vec2<i32>(id.xy), vec4<f32>(toned(c, resolved.tone), 1.0));
}
