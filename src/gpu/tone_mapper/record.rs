//! How a [`ToneMapper`] records one frame: the input's wiring found (or
//! made) by what it depends on, this record's uniform values copied in by
//! its own encoder, then the executor's passes (the gate renderer's, each
//! stage in a pass of its own when timed) with the write into the target
//! as their tail on the compute path, or a fullscreen triangle after them.

use super::{
    taa, timing, Bound, MotionVectors, SourceView, TargetView, ToneMapper, ToneMapperError,
    KEPT_INPUTS,
};
use crate::gpu::adaptation::Steps;
use crate::gpu::exec::{self, ComputeStamps, Draw};
use crate::gpu::stages::ImageView;

impl ToneMapper {
    /// Records the tone mapping of `input` into `output`: the statistics
    /// and the curve as one compute pass of `encoder`, and the target
    /// written in that pass or in a render pass after it; nothing is
    /// submitted.
    ///
    /// `input`: a view of a texture in one of [`INPUT_FORMATS`](super::INPUT_FORMATS), with
    /// `TEXTURE_BINDING`. `output`: a view in the settings' `target`
    /// format, with `STORAGE_BINDING` for the compute path or
    /// `RENDER_ATTACHMENT` for the render pass, holding the image's size at
    /// its origin. Either being otherwise is an error that says which and
    /// why, before anything is recorded. The record maps with the settings
    /// in effect now, whatever is set before the encoder is submitted.
    /// Resources are kept by input (the last few) and shared by every
    /// target: a new target view each frame (a swap chain's) creates no
    /// texture.
    pub fn record<'a>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        input: impl Into<SourceView<'a>>,
        output: impl Into<TargetView<'a>>,
    ) -> Result<(), ToneMapperError> {
        self.record_frame(encoder, input.into(), None, output.into())
    }

    /// [`ToneMapper::record`] and [`ToneMapper::record_with_motion`].
    pub(super) fn record_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        input: SourceView,
        motion: Option<MotionVectors>,
        output: TargetView,
    ) -> Result<(), ToneMapperError> {
        let (key, sink) = self.key(&input, motion.as_ref(), &output)?;
        let size = key.size;
        match self.bound.iter().position(|b| b.key == key) {
            Some(i) => {
                let b = self.bound.remove(i);
                self.bound.push(b);
            }
            None => {
                let source = ImageView {
                    view: key.input.clone(),
                    width: key.size.0,
                    height: key.size.1,
                };
                let wired = self.wire(&source, key.motion.as_ref())?;
                // A history of a new size: the inputs wired to the old one
                // go with it, and the frame starts a new history.
                let old = self.history.resources.as_ref().map(|r| &r.uniforms);
                if wired.history.as_ref().map(|r| &r.uniforms) != old {
                    self.bound.clear();
                    self.history = taa::History {
                        resources: wired.history.clone(),
                        ..taa::History::default()
                    };
                }
                if self.bound.len() == KEPT_INPUTS {
                    self.bound.remove(0);
                }
                self.bound.push(Bound { key, wired });
            }
        }
        // This record's values, copied in by its own encoder.
        let ctx = &self.ctx;
        let words: &[f32] = &self.config;
        self.ring.stage(
            ctx,
            encoder,
            &self.shader.config,
            bytemuck::cast_slice(words),
        );
        let origin = [sink.origin.0, sink.origin.1, 0, 0];
        self.ring
            .stage(ctx, encoder, &self.origin, bytemuck::cast_slice(&origin));
        let adapting = self.settings.adaptation.is_some();
        if let Some(adaptation) = &self.settings.adaptation {
            let reset = &mut self.cameras.reset[self.cameras.current];
            let steps = Steps::new(adaptation, self.frame_seconds, *reset);
            self.ring
                .stage(ctx, encoder, &self.steps, bytemuck::bytes_of(&steps));
            *reset = false;
            self.cameras.load(encoder, &self.adapted);
        }
        let odd = self.step_history(encoder, motion.as_ref(), size);
        let store = sink.compute.then(|| self.store_for(sink.view));
        if !sink.compute {
            self.draw_for_last();
        }
        let bound = self.bound.last().expect("bound above");
        let exec = &bound.wired.exec;
        let compute = self.stamps.as_ref().map(|s| |i| s.compute(i));
        let compute = compute.as_ref().map(|f| f as ComputeStamps);
        exec.record(
            encoder,
            odd,
            store.as_ref(),
            compute,
            "tonegate.tone_mapper",
        );
        if adapting {
            self.cameras.store(encoder, &self.adapted);
        }
        if let (false, Some((pipeline, bind_group))) = (sink.compute, &bound.wired.draw) {
            let draw = Draw {
                pipeline,
                bind_group,
                view: sink.view,
                origin: sink.origin,
                size,
            };
            exec::draw(
                encoder,
                draw,
                self.stamps.as_ref().map(timing::Stamps::render),
            );
        }
        let rendered = !sink.compute;
        if let Some(stamps) = &mut self.stamps {
            let mut names = exec.stage_names();
            if store.is_some() {
                names.push("target");
            }
            stamps.resolve(encoder, names, rendered);
        }
        Ok(())
    }
}
