//! `tonemap` pass: resolve the curve's parameters from the statistics (one
//! invocation), then tone-map every pixel.

use super::stages::{bind_group, dispatch_2d, pipeline, uniform_buffer, Bind, Dispatch};
use super::{GpuContext, HdrFormat};
use crate::reference::tonemap::{invert3, operator_constants, rgb_to_xyz};
use crate::scene::{ColourPath, Key, Operator};

/// The operator's constants as the shader's `ToneConfig` (36 f32: the weights
/// and six matrix rows as vec4s, then five scalars and three pads).
pub fn tone_config(op: &Operator) -> [f32; 36] {
    let (weights, _) = operator_constants(op);
    let to_xyz = rgb_to_xyz(weights);
    let to_rgb = invert3(to_xyz);
    let mut c = [0f32; 36];
    let row = |c: &mut [f32; 36], at: usize, v: [f64; 3]| {
        c[at] = v[0] as f32;
        c[at + 1] = v[1] as f32;
        c[at + 2] = v[2] as f32;
    };
    row(&mut c, 0, weights);
    for i in 0..3 {
        row(&mut c, 4 + 4 * i, to_xyz[i]);
        row(&mut c, 16 + 4 * i, to_rgb[i]);
    }
    let (key, white_fraction, white, fixed_lavg, fixed_max) = match op {
        Operator::ReinhardGlobal {
            key,
            white_fraction,
            log_average,
            max_luminance,
            ..
        } => (
            key.get(),
            white_fraction.get(),
            0.0,
            log_average.map(|v| v.get()).unwrap_or(0.0),
            max_luminance.map(|v| v.get()).unwrap_or(0.0),
        ),
        Operator::ReinhardAutoKey { key, .. } => (
            match key {
                Key::Fixed(k) => k.get(),
                Key::Auto => 0.18,
            },
            1.0,
            0.0,
            0.0,
            0.0,
        ),
        Operator::Reinhard02 {
            key,
            white,
            log_average,
            ..
        } => (
            key.get(),
            1.0,
            white.map(|v| v.get()).unwrap_or(0.0),
            log_average.map(|v| v.get()).unwrap_or(0.0),
            0.0,
        ),
    };
    c[28] = key as f32;
    c[29] = white_fraction as f32;
    c[30] = white as f32;
    c[31] = fixed_lavg as f32;
    c[32] = fixed_max as f32;
    c
}

/// The shader's `OPERATOR` override constant: 0 `reinhard-global`, 1
/// `reinhard-auto-key`, 2 `reinhard02`.
pub fn operator_code(op: &Operator) -> u32 {
    match op {
        Operator::ReinhardGlobal { .. } => 0,
        Operator::ReinhardAutoKey { .. } => 1,
        Operator::Reinhard02 { .. } => 2,
    }
}

/// The operator's override constants and its `ToneConfig` uniform, shared by
/// the `tonemap` stage and the fused kernels.
pub struct ToneParams {
    pub config: wgpu::Buffer,
    pub operator: f64,
    pub colour: f64,
    pub auto_key: f64,
    pub fault_gain: f64,
}

impl ToneParams {
    pub fn new(ctx: &GpuContext, op: &Operator, fault_gain: Option<f32>) -> ToneParams {
        ToneParams {
            config: uniform_buffer(
                ctx,
                "tonegate.tonemap.config",
                bytemuck::cast_slice(&tone_config(op)),
            ),
            operator: operator_code(op) as f64,
            colour: (op.colour() == ColourPath::Xyy) as u32 as f64,
            auto_key: matches!(op, Operator::ReinhardAutoKey { key: Key::Auto, .. }) as u32 as f64,
            fault_gain: fault_gain.unwrap_or(1.0) as f64,
        }
    }

    fn constants(&self) -> [(&'static str, f64); 4] {
        [
            ("OPERATOR", self.operator),
            ("COLOUR", self.colour),
            ("AUTO_KEY", self.auto_key),
            ("FAULT_GAIN", self.fault_gain),
        ]
    }
}

/// The one-invocation step that turns the statistics into the curve's
/// parameters (scale, white) in `stats`.
pub fn resolve(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &ToneParams,
    stats: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(ctx, "tonemap", "resolve", format, &params.constants());
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.tonemap.resolve",
        &[(0, Bind::Buffer(&params.config)), (1, Bind::Buffer(stats))],
    );
    Dispatch::new(p, bg, (1, 1))
}

pub fn tonemap(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &ToneParams,
    stats: &wgpu::Buffer,
    hdr: &wgpu::Texture,
    toned_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Vec<Dispatch> {
    let main = pipeline(ctx, "tonemap", "main", format, &params.constants());
    let bg = bind_group(
        ctx,
        &main,
        "tonegate.tonemap",
        &[
            (0, Bind::Buffer(&params.config)),
            (2, Bind::Texture(hdr)),
            (3, Bind::Texture(toned_out)),
            (4, Bind::Buffer(stats)),
        ],
    );
    vec![
        resolve(ctx, format, params, stats),
        dispatch_2d(main, bg, hdr.width(), hdr.height()).sized(ctx, extent),
    ]
}
