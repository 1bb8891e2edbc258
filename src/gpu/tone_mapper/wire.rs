//! How a [`ToneMapper`] checks a pair of views and wires its passes
//! between them: the statistics, the adaptation, the curve, and the target
//! written by a compute pass or a fullscreen triangle.

use super::target::{check_texture, level_size, TextureRole, ToneMapperError, INPUT_FORMATS};
use super::{BoundKey, Draw, SourceView, TargetView, ToneMapper};
use crate::gpu::encode::{
    encode_render_bind_group, encode_render_pipeline, encode_to_storage, Texel,
};
use crate::gpu::stages::{extent_buffer, hdr_texture, uniform_buffer, Dispatch, Extent, ImageView};
use crate::gpu::HdrFormat;
use crate::reference::adaptation::{keys_on_average, measured_needs};

impl ToneMapper {
    /// The pair's key, or why the mapper cannot use it.
    pub(super) fn key(
        &self,
        input: &SourceView,
        output: &TargetView,
    ) -> Result<BoundKey, ToneMapperError> {
        use wgpu::TextureUsages as U;
        let (itex, otex) = (input.view.texture(), output.view.texture());
        if !INPUT_FORMATS.contains(&itex.format()) {
            return Err(ToneMapperError::InputFormat {
                format: itex.format(),
            });
        }
        let target = self.settings.target;
        if otex.format().remove_srgb_suffix() != target.remove_srgb_suffix() {
            return Err(ToneMapperError::OutputFormat {
                format: otex.format(),
                target,
            });
        }
        check_texture(itex, TextureRole::Input, U::TEXTURE_BINDING)?;
        let (compute, render) = self.paths();
        let compute = match (compute, render) {
            (true, true) => otex.usage().contains(U::STORAGE_BINDING),
            (compute, _) => compute,
        };
        let usage = if compute {
            U::STORAGE_BINDING
        } else {
            U::RENDER_ATTACHMENT
        };
        check_texture(otex, TextureRole::Output, usage)?;
        let level = level_size(itex, TextureRole::Input, input.mip_level)?;
        let size = input.size.unwrap_or(level);
        if size.0 == 0 || size.1 == 0 || size.0 > level.0 || size.1 > level.1 {
            return Err(ToneMapperError::Outside {
                texture: TextureRole::Input,
                region: (0, 0, size.0, size.1),
                level,
            });
        }
        let out_level = level_size(otex, TextureRole::Output, output.mip_level)?;
        let origin = match output.origin {
            None if out_level != size => {
                return Err(ToneMapperError::SizeMismatch {
                    input: size,
                    output: out_level,
                })
            }
            None => (0, 0),
            Some((x, y)) => {
                let fits = |o: u32, s: u32, l: u32| o.checked_add(s).is_some_and(|e| e <= l);
                if !fits(x, size.0, out_level.0) || !fits(y, size.1, out_level.1) {
                    return Err(ToneMapperError::Outside {
                        texture: TextureRole::Output,
                        region: (x, y, size.0, size.1),
                        level: out_level,
                    });
                }
                (x, y)
            }
        };
        self.ctx
            .check_frame(size.0, size.1)
            .map_err(ToneMapperError::Limits)?;
        Ok(BoundKey {
            input: input.view.clone(),
            size,
            output: output.view.clone(),
            origin,
            compute,
        })
    }

    /// The render pipeline into the settings' target, compiled once.
    pub(super) fn render_pipeline(&mut self) -> wgpu::RenderPipeline {
        let s = &self.settings;
        let levels = s.operator.display_levels();
        let texel = Texel::of(s.target).expect("checked by check_settings");
        let constants = crate::gpu::encode::target_constants(s.encoding, levels, texel);
        let key = (
            s.target,
            constants
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.to_bits()))
                .collect(),
        );
        let ctx = &self.ctx;
        self.render
            .entry(key)
            .or_insert_with(|| encode_render_pipeline(ctx, s.encoding, levels, s.target))
            .clone()
    }

    /// The work from `input` to `output`: statistics, tone map, and the
    /// target written by a last dispatch (`compute`) or a draw, with an
    /// intermediate texture for the tone-mapped frame.
    pub(super) fn wire(
        &mut self,
        input: &ImageView,
        output: &wgpu::TextureView,
        origin: (u32, u32),
        compute: bool,
    ) -> (Vec<Dispatch>, Option<Draw>) {
        // Intermediates in f32, as tonegate's renderer keeps them by default.
        let format = HdrFormat::Rgba32Float;
        let (width, height) = (input.width, input.height);
        self.params.exposed =
            self.settings.adaptation.is_some() && !keys_on_average(self.settings.operator.needs());
        let ctx = &self.ctx;
        let extent = extent_buffer(
            ctx,
            Extent {
                frame: [width, height],
                low: [width.div_ceil(2).max(1), height.div_ceil(2).max(1)],
            },
        );
        let op = &self.settings.operator;
        let mut dispatches = Vec::new();
        let adapting = self.settings.adaptation.is_some();
        let needs = op.needs();
        let measured = if adapting {
            measured_needs(needs)
        } else {
            needs
        };
        if measured.any() {
            let lum = op.luminance();
            dispatches.extend(crate::gpu::luminance_stats::luminance_stats(
                ctx,
                format,
                self.reduction,
                measured,
                lum.weights,
                lum.delta,
                input,
                &self.stats,
                &extent,
            ));
        }
        if adapting {
            dispatches.push(crate::gpu::adaptation::adaptation(
                ctx,
                format,
                needs,
                &self.stats,
                &self.adapted,
                &self.steps,
            ));
        }
        let toned = hdr_texture(ctx, "tonegate.tonemap", width, height, format);
        dispatches.extend(crate::gpu::tonemap::tonemap(
            ctx,
            format,
            &self.params,
            &self.stats,
            input,
            &toned,
            &extent,
        ));
        let origin_words = [origin.0, origin.1, 0, 0];
        let origin = uniform_buffer(
            ctx,
            "tonegate.encode.target_origin",
            bytemuck::cast_slice(&origin_words),
        );
        let s = &self.settings;
        if compute {
            dispatches.push(encode_to_storage(
                ctx,
                format,
                s.encoding,
                s.operator.display_levels(),
                &toned,
                output,
                s.target,
                &origin,
                &extent,
            ));
            return (dispatches, None);
        }
        let pipeline = self.render_pipeline();
        let bind_group = encode_render_bind_group(&self.ctx, &pipeline, &toned, &origin);
        (
            dispatches,
            Some(Draw {
                pipeline,
                bind_group,
            }),
        )
    }
}
