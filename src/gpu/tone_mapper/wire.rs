//! How a [`ToneMapper`] checks a pair of views and wires its passes
//! between them: the statistics, the adaptation, the curve, and the target
//! written by a compute pass or a fullscreen triangle.

use super::target::{check_texture, level_size, TextureRole, ToneMapperError, INPUT_FORMATS};
use super::{BoundKey, Draw, MotionVectors, SourceView, TargetView, ToneMapper, Wired};
use crate::gpu::adaptation::AdaptationResources;
use crate::gpu::encode::{
    encode_render_bind_group, encode_render_pipeline, encode_to_storage, Texel,
};
use crate::gpu::renderer::extent_of;
use crate::gpu::stages::{extent_buffer, uniform_buffer, ImageView};
use crate::gpu::wiring::Wiring;
use crate::gpu::GpuInput;
use crate::gpu::{GpuConfig, GpuError};
use crate::plan::{AdaptationStage, Input, PlanError, Stage, StagePlan};
use crate::reference::Pipeline;

impl ToneMapper {
    /// The pair's key, or why the mapper cannot use it.
    pub(super) fn key(
        &self,
        input: &SourceView,
        motion: Option<&MotionVectors>,
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
        let motion = self.motion_key(itex, input.mip_level, size, motion)?;
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
            motion,
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

    /// The plan the settings make: `StagePlan::build`'s for a flat image
    /// with the settings' bloom and grade, and TAA and adaptation when on.
    pub(super) fn plan(&self) -> StagePlan {
        let s = &self.settings;
        let mut plan =
            StagePlan::build(Input::Flat, &s.operator, s.bloom.as_ref(), s.grade.as_ref());
        if let Some(taa) = &s.taa {
            plan = plan.with_taa(taa.params());
        }
        match s.adaptation {
            Some(adaptation) => plan.with_adaptation(AdaptationStage {
                adaptation,
                frame_seconds: self.frame_seconds,
                operator_needs: s.operator.needs(),
            }),
            None => plan,
        }
    }

    /// The work from `input` to `output` at `origin`: the plan's stages up
    /// to `encode`, wired by tonegate's own renderer's code
    /// (`Wiring::staged`), reading the caller's views and the mapper's own
    /// statistics, operator uniform, adapted state and TAA history; then
    /// the target written from the display image by a last dispatch
    /// (`compute`) or a draw.
    pub(super) fn wire(
        &mut self,
        input: &ImageView,
        (output, origin): (&wgpu::TextureView, (u32, u32)),
        compute: bool,
        motion: Option<&wgpu::TextureView>,
    ) -> Result<Wired, ToneMapperError> {
        let plan = self.plan();
        let s = &self.settings;
        let pipeline = Pipeline {
            operator: &s.operator,
            bloom: s.bloom.as_ref(),
            grade: s.grade.as_ref(),
            encoding: s.encoding,
        };
        // The reduction tonegate's own renderer picks on this adapter, and
        // its f32 intermediates.
        let config = GpuConfig {
            reduction: self.reduction,
            ..GpuConfig::default()
        };
        let (width, height) = (input.width, input.height);
        let bloom_factor = s.bloom.as_ref().map(|b| b.downsample.get());
        let extent = extent_buffer(&self.ctx, extent_of((width, height), bloom_factor));
        let internal = ToneMapperError::Internal;
        let source = GpuInput::View(input);
        let mut wiring = Wiring::new(
            &self.ctx,
            &source,
            &pipeline,
            config,
            (width, height),
            motion.is_some(),
            extent.clone(),
        )
        .map_err(internal)?;
        wiring.stats = self.stats.clone();
        wiring.shader = Some(self.shader.clone());
        wiring.adaptation = plan.adaptation().map(|stage| AdaptationResources {
            stage,
            adapted: self.adapted.clone(),
            steps: self.steps.clone(),
        });
        wiring.motion = motion.cloned();
        wiring.taa = self.history.resources.clone();
        // One list of dispatches for each texture of the TAA history pair
        // a frame may read.
        let (mut even, mut odd, mut parity) = (Vec::new(), Vec::new(), false);
        let mut stages = Vec::new();
        for stage in plan.stages() {
            if matches!(stage, Stage::Encode) {
                break;
            }
            let pass = wiring.staged(stage).map_err(internal)?;
            stages.push((stage.name(), pass.dispatches.len()));
            match pass.odd {
                Some(o) => {
                    odd.extend(o);
                    parity = true;
                }
                None => odd.extend(pass.dispatches.iter().cloned()),
            }
            even.extend(pass.dispatches);
        }
        let display = wiring
            .display
            .clone()
            .ok_or(ToneMapperError::Internal(GpuError::Plan(PlanError::order(
                "encode", "tonemap",
            ))))?;
        let origin_words = [origin.0, origin.1, 0, 0];
        let origin = uniform_buffer(
            &self.ctx,
            "tonegate.encode.target_origin",
            bytemuck::cast_slice(&origin_words),
        );
        let history = wiring.taa.clone();
        let odd = parity.then_some(odd);
        if compute {
            let last = encode_to_storage(
                &self.ctx,
                config.hdr_format,
                s.encoding,
                s.operator.display_levels(),
                &display,
                output,
                s.target,
                &origin,
                &extent,
            );
            let odd = odd.map(|mut o| {
                o.push(last.clone());
                o
            });
            even.push(last);
            stages.push(("target", 1));
            return Ok(Wired {
                even,
                odd,
                stages,
                draw: None,
                history,
            });
        }
        let pipeline = self.render_pipeline();
        let bind_group = encode_render_bind_group(&self.ctx, &pipeline, &display, &origin);
        Ok(Wired {
            even,
            odd,
            stages,
            draw: Some(Draw {
                pipeline,
                bind_group,
            }),
            history,
        })
    }
}
