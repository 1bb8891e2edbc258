//! How a [`ToneMapper`] checks a pair of views and wires its passes: from
//! an input to its display image (the statistics, the adaptation, the
//! curve, bloom and grade), kept by input; then that image written into
//! each target by a compute pass or a fullscreen triangle.

use super::target::{check_texture, level_size, TextureRole, ToneMapperError, INPUT_FORMATS};
use super::{
    MotionVectors, Sink, SourceView, TargetView, ToneMapper, Wired, WiredKey, KEPT_TARGETS,
};
use crate::gpu::adaptation::AdaptationResources;
use crate::gpu::encode::{encode_render_bind_group, encode_render_pipeline, encode_to_storage};
use crate::gpu::exec::Executor;
use crate::gpu::stages::{extent_buffer, extent_of, Dispatch, ImageView};
use crate::gpu::wiring::Wiring;
use crate::gpu::GpuInput;
use crate::gpu::{GpuConfig, GpuError};
use crate::plan::{AdaptationStage, Input, PlanError, Stage, StagePlan};
use crate::reference::Pipeline;

impl ToneMapper {
    /// The input's key and the record's sink, or why the mapper cannot
    /// use the pair.
    pub(super) fn key<'v>(
        &self,
        input: &SourceView,
        motion: Option<&MotionVectors>,
        output: &TargetView<'v>,
    ) -> Result<(WiredKey, Sink<'v>), ToneMapperError> {
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
        let key = WiredKey {
            input: input.view.clone(),
            size,
            motion,
        };
        let sink = Sink {
            view: output.view,
            origin,
            compute,
        };
        Ok((key, sink))
    }

    /// The compute path's last dispatch from `wired`'s display image into
    /// the storage target `view`: its pipeline from the context's cache,
    /// two bind groups of its own.
    pub(super) fn store_dispatch(&self, wired: &Wired, view: &wgpu::TextureView) -> Dispatch {
        let s = &self.settings;
        encode_to_storage(
            &self.ctx,
            GpuConfig::default().hdr_format,
            s.encoding,
            s.operator.display_levels(),
            &wired.display,
            view,
            s.target,
            &self.origin,
            &wired.extent,
        )
    }

    /// The dispatch into storage target `view` from the input used last:
    /// kept for the last [`KEPT_TARGETS`] views, made for another.
    pub(super) fn store_for(&mut self, view: &wgpu::TextureView) -> Dispatch {
        let wired = &self.bound.last().expect("an input is bound").wired;
        if let Some(i) = wired.stores.iter().position(|(v, _)| v == view) {
            return wired.stores[i].1.clone();
        }
        let store = self.store_dispatch(wired, view);
        let stores = &mut self.bound.last_mut().expect("bound").wired.stores;
        if stores.len() == KEPT_TARGETS {
            stores.remove(0);
        }
        stores.push((view.clone(), store.clone()));
        store
    }

    /// The render pipeline into the settings' target (compiled once, in
    /// the context's cache) and its bind group reading `display`.
    pub(super) fn draw(&self, display: &wgpu::Texture) -> (wgpu::RenderPipeline, wgpu::BindGroup) {
        let s = &self.settings;
        let pipeline =
            encode_render_pipeline(&self.ctx, s.encoding, s.operator.display_levels(), s.target);
        let bind_group = encode_render_bind_group(&self.ctx, &pipeline, display, &self.origin);
        (pipeline, bind_group)
    }

    /// The input used last gets its draw into a render attachment, once.
    pub(super) fn draw_for_last(&mut self) {
        let wired = &self.bound.last().expect("an input is bound").wired;
        if wired.draw.is_none() {
            let draw = self.draw(&wired.display);
            self.bound.last_mut().expect("bound").wired.draw = Some(draw);
        }
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

    /// The work from `input` to its display image: the plan's stages up
    /// to `encode`, wired by tonegate's own renderer's code
    /// (`Wiring::staged`), reading the caller's views and the mapper's own
    /// statistics, operator uniform, adapted state and TAA history. What
    /// writes the image into a target is made per target
    /// ([`ToneMapper::store_for`], [`ToneMapper::draw_for_last`]).
    pub(super) fn wire(
        &mut self,
        input: &ImageView,
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
            bins: self.bins.clone(),
        });
        wiring.motion = motion.cloned();
        wiring.taa = self.history.resources.clone();
        let exec = Executor::wire(
            &mut wiring,
            &plan,
            crate::gpu::Execution::Staged,
            Some(Stage::Encode.name()),
        )
        .map_err(internal)?;
        let display = wiring
            .display
            .clone()
            .ok_or(ToneMapperError::Internal(GpuError::Plan(PlanError::order(
                "encode", "tonemap",
            ))))?;
        let history = wiring.taa.clone();
        Ok(Wired {
            exec,
            display,
            extent,
            history,
            draw: None,
            stores: Vec::new(),
        })
    }
}
