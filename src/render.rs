//! Rendering a scene's frames on either renderer at any spp: the one frame
//! loop `check`, `render`, `tradeoff` and the goldens share.

use crate::check::Rendered;
use crate::conventions::rotation_matrix;
use crate::gpu::{GpuConfig, GpuContext, GpuError, GpuFrame, GpuInput, GpuRenderer, GpuStats};
use crate::image::{HdrImage, Rgb8Image};
use crate::perf::{summarise, StageTiming};
use crate::plan::{PlanError, StagePlan};
use crate::reference::{render_frame, scene_camera, FrameSummary, Pipeline};
use crate::scene::{Scene, Size};
use std::time::Instant;

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

/// What a frame's renderer reports besides the image.
#[derive(Clone, Debug)]
pub enum FrameDetail {
    /// The reference's statistics and resolved operator parameters.
    Cpu(FrameSummary),
    /// The GPU's statistics and each stage's time.
    Gpu {
        stats: GpuStats,
        timings: Vec<StageTiming>,
    },
}

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    pub index: u32,
    /// The encoded 8-bit frame.
    pub image: Rgb8Image,
    /// Host time for the frame, GPU readback included.
    pub wall_ms: f64,
    pub detail: FrameDetail,
}

impl RenderedFrame {
    /// The adaptation luminance the operator used (the log-average, or the
    /// fixed value that replaced it).
    pub fn adaptation(&self) -> f64 {
        match &self.detail {
            FrameDetail::Cpu(s) => s.tone.log_average,
            FrameDetail::Gpu { stats, .. } => f64::from(stats.adaptation),
        }
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
}

impl<'a> SceneRenderer<'a> {
    /// The CPU reference (f64).
    pub fn cpu(scene: &'a Scene, env: &'a HdrImage, spp: u32) -> Self {
        SceneRenderer {
            scene,
            env,
            spp,
            engine: Engine::Cpu,
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
            engine: Engine::Gpu(Box::new(renderer)),
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
            Engine::Cpu => "cpu-reference".into(),
            Engine::Gpu(r) => r.adapter_name().into(),
        }
    }

    /// Renders frame `n`, read back.
    pub fn frame(&self, n: u32) -> Result<RenderedFrame, RenderError> {
        let start = Instant::now();
        match &self.engine {
            Engine::Cpu => {
                let out = render_frame(self.scene, self.env, n, self.spp).map_err(|source| {
                    RenderError::Plan {
                        scene: self.scene.name.clone(),
                        source,
                    }
                })?;
                Ok(RenderedFrame {
                    index: n,
                    image: out.frame,
                    wall_ms: start.elapsed().as_secs_f64() * 1e3,
                    detail: FrameDetail::Cpu(FrameSummary {
                        stats: out.stats,
                        tone: out.tone,
                    }),
                })
            }
            Engine::Gpu(r) => {
                let out = self.gpu_frame(r, n, true)?;
                let image = out
                    .frame
                    .ok_or_else(|| self.gpu_error(GpuError::Readback("no frame".into())))?;
                Ok(RenderedFrame {
                    index: n,
                    image,
                    wall_ms: out.wall_ms,
                    detail: FrameDetail::Gpu {
                        stats: out.stats,
                        timings: out.timings,
                    },
                })
            }
        }
    }

    /// Renders frame `n` without reading it back and returns its stage
    /// times: what timing runs repeat. Empty on the CPU.
    pub fn stage_times(&self, n: u32) -> Result<Vec<StageTiming>, RenderError> {
        match &self.engine {
            Engine::Cpu => Ok(Vec::new()),
            Engine::Gpu(r) => Ok(self.gpu_frame(r, n, false)?.timings),
        }
    }

    fn gpu_frame(&self, r: &GpuRenderer, n: u32, read_back: bool) -> Result<GpuFrame, RenderError> {
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

    /// Renders every frame of the sequence for the gate: the images, the
    /// stage times' medians and, on the GPU, the FPS with readback.
    /// `progress` is told after each frame.
    pub fn sequence(&self, mut progress: impl FnMut(u32)) -> Result<Rendered, RenderError> {
        let mut frames = Vec::with_capacity(self.scene.frames as usize);
        let mut times = Vec::with_capacity(self.scene.frames as usize);
        let mut wall = 0.0;
        for n in 0..self.scene.frames {
            let out = self.frame(n)?;
            wall += out.wall_ms;
            if let FrameDetail::Gpu { timings, .. } = out.detail {
                times.push(timings);
            }
            frames.push(out.image);
            progress(n);
        }
        let (renderer, fps) = match &self.engine {
            Engine::Cpu => (format!("cpu-reference ({} spp)", self.spp), None),
            Engine::Gpu(r) => (
                r.adapter_name().to_owned(),
                Some(self.scene.frames as f64 / (wall / 1e3)),
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
        })
    }
}
