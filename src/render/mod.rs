//! Rendering a scene's frames on either renderer at any spp: the one frame
//! loop `check`, `render`, `tradeoff` and the goldens share.

use crate::check::Rendered;
use crate::conventions::{reprojection, rotation_matrix, taa_jitter, Mat3};
use crate::gpu::{GpuConfig, GpuContext, GpuError, GpuFrame, GpuInput, GpuRenderer};
use crate::image::{Frame, HdrImage, Rgb8Image};
use crate::perf::{summarise, StageTiming};
use crate::plan::{PlanError, StagePlan};
use crate::reference::{render_carried_frame, render_frame, scene_camera, Pipeline};
use crate::scene::{Scene, Size};
use std::time::Instant;

mod frame;

pub use frame::{FrameDetail, RenderedFrame};

/// The name a CPU-reference render goes by wherever an adapter's name would
/// stand (reports, the history, JUnit).
pub const CPU_REFERENCE: &str = "cpu-reference";

/// What renders: the CPU reference in f64, or the GPU pipeline on an
/// adapter with its configuration.
#[derive(Clone, Debug)]
pub enum Renderer {
    Cpu,
    Gpu {
        adapter: crate::gpu::AdapterChoice,
        config: GpuConfig,
    },
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene's environment file could not be read.
    #[error("scene {scene}: {source}")]
    Environment {
        scene: String,
        source: crate::io::HdrIoError,
    },
    /// The scene names no environment (validation refuses such scenes).
    #[error("scene {scene}: no environment")]
    NoEnvironment { scene: String },
    /// The GPU failed while rendering the scene.
    #[error("scene {scene}: {source}")]
    Gpu { scene: String, source: GpuError },
    /// The reference met a plan it cannot execute (a tonegate bug).
    #[error("scene {scene}: {source}")]
    Plan { scene: String, source: PlanError },
}

/// The environment map of a scene: generated, or loaded with the default policy.
pub fn scene_environment(scene: &Scene) -> Result<HdrImage, RenderError> {
    match (&scene.environment.builtin, &scene.environment.path) {
        (Some(env), _) => {
            let size = scene.environment.size.unwrap_or(Size {
                width: 1024,
                height: 512,
            });
            Ok(env.generate(size.width, size.height))
        }
        (None, Some(path)) => crate::io::load_hdr(path, &crate::io::LoadOptions::default())
            .map(|(img, _)| img)
            .map_err(|source| RenderError::Environment {
                scene: scene.name.clone(),
                source,
            }),
        (None, None) => Err(RenderError::NoEnvironment {
            scene: scene.name.clone(),
        }),
    }
}

enum Engine<'a> {
    Cpu,
    Gpu(Box<GpuRenderer<'a>>),
}

/// A scene set up to render any of its frames on one renderer at one spp.
pub struct SceneRenderer<'a> {
    scene: &'a Scene,
    env: &'a HdrImage,
    spp: u32,
    engine: Engine<'a>,
    /// Whether the plan has TAA, whose frames depend on the frames before.
    taa: bool,
    /// Whether the plan has eye adaptation, whose frames do too.
    adapting: bool,
    history: std::sync::Mutex<Carried>,
}

/// Where a sequence's state carried from frame to frame stands: the TAA
/// history and the adapted luminance.
#[derive(Default)]
struct Carried {
    /// The frame the state is ready for (None: no usable state).
    next: Option<u32>,
    /// The CPU reference's TAA history (the GPU keeps its own on the device).
    cpu: Option<crate::reference::taa::TaaHistory>,
    /// The CPU reference's adapted luminance (the GPU's is on the device).
    cpu_adapted: Option<crate::reference::adaptation::Adapted>,
}

impl<'a> SceneRenderer<'a> {
    /// The CPU reference (f64).
    pub fn cpu(scene: &'a Scene, env: &'a HdrImage, spp: u32) -> Self {
        SceneRenderer {
            scene,
            env,
            spp,
            engine: Engine::Cpu,
            taa: StagePlan::for_scene(scene, spp).taa().is_some(),
            adapting: scene.adaptation.is_some(),
            history: Default::default(),
        }
    }

    /// The GPU pipeline: the plan's passes are built once, here.
    pub fn gpu(
        scene: &'a Scene,
        env: &'a HdrImage,
        ctx: &'a GpuContext,
        config: GpuConfig,
        spp: u32,
    ) -> Result<Self, RenderError> {
        let renderer = GpuRenderer::new(
            ctx,
            StagePlan::for_scene(scene, spp),
            GpuInput::Sphere {
                env,
                camera: scene_camera(scene),
                spp,
                light: scene.brightest_light() as f32,
            },
            &Pipeline::of_scene(scene),
            config,
        )
        .map_err(|source| RenderError::Gpu {
            scene: scene.name.clone(),
            source,
        })?;
        Ok(SceneRenderer {
            scene,
            env,
            spp,
            taa: renderer.has_taa(),
            adapting: renderer.has_adaptation(),
            engine: Engine::Gpu(Box::new(renderer)),
            history: Default::default(),
        })
    }

    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// The stages every frame goes through.
    pub fn plan(&self) -> StagePlan {
        match &self.engine {
            Engine::Cpu => StagePlan::for_scene(self.scene, self.spp),
            Engine::Gpu(r) => r.plan.clone(),
        }
    }

    /// The GPU renderer, for the configuration in effect and its notes.
    pub fn gpu_renderer(&self) -> Option<&GpuRenderer<'a>> {
        match &self.engine {
            Engine::Cpu => None,
            Engine::Gpu(r) => Some(r),
        }
    }

    /// The adapter's name, or `cpu-reference`.
    pub fn adapter(&self) -> String {
        match &self.engine {
            Engine::Cpu => CPU_REFERENCE.into(),
            Engine::Gpu(r) => r.adapter_name().into(),
        }
    }

    /// Renders frame `n`, read back. A TAA frame needs the frames before it:
    /// when `n` does not follow the last frame rendered, the frames from the
    /// last history reset up to `n` are rendered first (not read back).
    pub fn frame(&self, n: u32) -> Result<RenderedFrame, RenderError> {
        if self.sequential() {
            return self.carried_frame(n);
        }
        let start = Instant::now();
        match &self.engine {
            Engine::Cpu => {
                let out = render_frame(self.scene, self.env, n, self.spp).map_err(|source| {
                    RenderError::Plan {
                        scene: self.scene.name.clone(),
                        source,
                    }
                })?;
                Ok(RenderedFrame::cpu(n, out, start))
            }
            Engine::Gpu(r) => {
                let out = self.gpu_frame(r, n, true)?;
                RenderedFrame::gpu(n, out).map_err(|e| self.gpu_error(e))
            }
        }
    }

    /// Renders frame `n` without reading it back and returns its stage
    /// times: what timing runs repeat. Empty on the CPU. A TAA frame is
    /// timed with a history to resolve against (its full cost), and the
    /// sequence's history is then spent: the next `frame` starts again from
    /// the last reset.
    pub fn stage_times(&self, n: u32) -> Result<Vec<StageTiming>, RenderError> {
        match &self.engine {
            Engine::Cpu => Ok(Vec::new()),
            Engine::Gpu(r) if self.sequential() => {
                self.lock_history().next = None;
                self.set_gpu_frame(r, n, true, false);
                Ok(r.render(false).map_err(|e| self.gpu_error(e))?.timings)
            }
            Engine::Gpu(r) => Ok(self.gpu_frame(r, n, false)?.timings),
        }
    }

    /// Whether a frame depends on the frames before it (TAA, adaptation).
    fn sequential(&self) -> bool {
        self.taa || self.adapting
    }

    /// Whether frame `k`'s TAA history is kept (not reset there).
    fn keeps_history(&self, k: u32) -> bool {
        self.scene.taa.as_ref().is_some_and(|t| !t.resets_at(k))
    }

    /// The frame a replay up to `n` starts from: where every state the
    /// sequence carries starts over (adaptation only at frame 0).
    fn replay_from(&self, n: u32) -> u32 {
        if self.adapting {
            return 0;
        }
        (0..=n).rev().find(|&k| !self.keeps_history(k)).unwrap_or(0)
    }

    fn lock_history(&self) -> std::sync::MutexGuard<'_, Carried> {
        self.history
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn rotation(&self, n: u32) -> Mat3 {
        rotation_matrix(self.scene.rotation.axis, self.scene.angle(n))
    }

    /// Sets frame `n`'s light, adaptation step, rotation and, in a TAA
    /// plan, jitter and history on the GPU; `history` false resets the TAA
    /// history, `reset` the adapted luminance.
    fn set_gpu_frame(&self, r: &GpuRenderer, n: u32, history: bool, reset: bool) {
        r.set_light(self.scene.light(n));
        r.set_adaptation(reset);
        let rotation = self.rotation(n);
        if !self.taa {
            r.set_rotation(&rotation);
            return;
        }
        r.set_frame(&rotation, taa_jitter(n));
        let m = match r.config.taa_fault {
            // The broken TAA of `check --taa-fault wrong-rotation`: the
            // history is read as if the sphere had not turned.
            Some(crate::gpu::TaaFault::WrongRotation) => reprojection(&rotation, &rotation),
            _ => reprojection(&self.rotation(n.saturating_sub(1)), &rotation),
        };
        r.set_taa_history(history.then_some(&m));
    }

    /// Frame `n` of a plan whose frames depend on the frames before (TAA,
    /// adaptation), with the frames it depends on.
    fn carried_frame(&self, n: u32) -> Result<RenderedFrame, RenderError> {
        let mut track = self.lock_history();
        let first = if track.next == Some(n) {
            n
        } else {
            self.replay_from(n)
        };
        let plan_error = |source| RenderError::Plan {
            scene: self.scene.name.clone(),
            source,
        };
        let mut last = None;
        for k in first..=n {
            let start = Instant::now();
            let keep = self.keeps_history(k);
            last = Some(match &self.engine {
                Engine::Cpu => {
                    let history = if keep { track.cpu.take() } else { None };
                    let adapted = if k == 0 {
                        None
                    } else {
                        track.cpu_adapted.take()
                    };
                    let (out, next, adapted) = render_carried_frame(
                        self.scene,
                        self.env,
                        k,
                        self.spp,
                        history.as_ref(),
                        adapted.as_ref(),
                    )
                    .map_err(plan_error)?;
                    track.cpu = next;
                    track.cpu_adapted = adapted;
                    RenderedFrame::cpu(k, out, start)
                }
                Engine::Gpu(r) => {
                    self.set_gpu_frame(r, k, keep, k == 0);
                    let out = r.render(k == n).map_err(|e| self.gpu_error(e))?;
                    RenderedFrame {
                        index: k,
                        image: out
                            .frame
                            .unwrap_or_else(|| Frame::Rgb8(Rgb8Image::filled(0, 0, [0; 3]))),
                        wall_ms: out.wall_ms,
                        detail: FrameDetail::Gpu {
                            stats: out.stats,
                            timings: out.timings,
                        },
                    }
                }
            });
            track.next = Some(k + 1);
        }
        last.ok_or_else(|| self.gpu_error(GpuError::Readback("no frame".into())))
    }

    fn gpu_frame(&self, r: &GpuRenderer, n: u32, read_back: bool) -> Result<GpuFrame, RenderError> {
        r.set_light(self.scene.light(n));
        r.set_rotation(&rotation_matrix(
            self.scene.rotation.axis,
            self.scene.angle(n),
        ));
        r.render(read_back).map_err(|e| self.gpu_error(e))
    }

    fn gpu_error(&self, source: GpuError) -> RenderError {
        RenderError::Gpu {
            scene: self.scene.name.clone(),
            source,
        }
    }

    /// Renders every frame of the sequence in order and hands each to
    /// `sink` as it reaches the host. On the GPU the frames are rendered
    /// with [`FRAMES_IN_FLIGHT`](crate::gpu::FRAMES_IN_FLIGHT) in
    /// flight: frame n is copied out, and `sink` works on it (writes a
    /// file, compares it), while n+1 renders.
    pub fn each_frame<E: From<RenderError>>(
        &self,
        mut sink: impl FnMut(RenderedFrame) -> Result<(), E>,
    ) -> Result<(), E> {
        let r = match &self.engine {
            Engine::Cpu => {
                for n in 0..self.scene.frames {
                    sink(self.frame(n)?)?;
                }
                return Ok(());
            }
            Engine::Gpu(r) => r,
        };
        /// The device's error or the sink's, through `GpuRenderer::frames`.
        enum Failed<E> {
            Gpu(GpuError),
            Sink(E),
        }
        impl<E> From<GpuError> for Failed<E> {
            fn from(e: GpuError) -> Self {
                Failed::Gpu(e)
            }
        }
        let mut track = self.lock_history();
        track.next = None;
        r.frames(
            0..self.scene.frames,
            |n| self.set_gpu_frame(r, n, self.keeps_history(n), n == 0),
            |_| true,
            |n, out| sink(RenderedFrame::gpu(n, out)?).map_err(Failed::Sink),
        )
        .map_err(|e| match e {
            Failed::Gpu(e) => E::from(self.gpu_error(e)),
            Failed::Sink(e) => e,
        })?;
        // The history now follows the last frame; after a failed sequence
        // `next` is None, so the next frame replays.
        if self.sequential() {
            track.next = Some(self.scene.frames);
        }
        Ok(())
    }

    /// Renders every frame of the sequence for the gate: the images, the
    /// stage times' medians and, on the GPU, the FPS with readback.
    /// `progress` is told after each frame. The frames go through
    /// [`SceneRenderer::each_frame`] (in flight on the GPU), and the FPS is
    /// frames over the whole sequence's wall time.
    pub fn sequence(&self, mut progress: impl FnMut(u32)) -> Result<Rendered, RenderError> {
        let mut frames = Vec::with_capacity(self.scene.frames as usize);
        let mut times = Vec::with_capacity(self.scene.frames as usize);
        let mut adapted = Vec::new();
        let start = Instant::now();
        self.each_frame(|f| -> Result<(), RenderError> {
            if self.adapting {
                adapted.extend(f.log_average());
            }
            if let FrameDetail::Gpu { timings, .. } = f.detail {
                times.push(timings);
            }
            frames.push(f.image);
            progress(f.index);
            if let Engine::Gpu(r) = &self.engine {
                if let Some(ms) = r.config.fault_delay_ms {
                    std::thread::sleep(std::time::Duration::from_millis(u64::from(ms)));
                }
            }
            Ok(())
        })?;
        let wall_s = start.elapsed().as_secs_f64();
        let (renderer, fps) = match &self.engine {
            Engine::Cpu => (format!("{CPU_REFERENCE} ({} spp)", self.spp), None),
            Engine::Gpu(r) => (
                r.adapter_name().to_owned(),
                Some(self.scene.frames as f64 / wall_s),
            ),
        };
        Ok(Rendered {
            renderer,
            adapter: self.adapter(),
            spp: self.spp,
            plan: self.plan().names(),
            frames,
            timings: summarise(&times),
            fps,
            options: match &self.engine {
                Engine::Cpu => Vec::new(),
                Engine::Gpu(r) => r.config.accuracy_options(),
            },
            adapted,
        })
    }
}
