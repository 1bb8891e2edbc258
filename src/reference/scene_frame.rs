//! A scene's frames on the reference: the sphere at the frame's rotation
//! (and jitter) under the frame's light, then the plan, with the state a
//! sequence carries from frame to frame (the TAA history, the adapted
//! luminance) given and returned.

use super::{adaptation, run_plan, run_plan_adapted, sphere, taa, taa_sobel};
use super::{FrameOutputs, Pipeline};
use crate::conventions::{rotation_matrix, Camera};
use crate::image::{HdrImage, LinearImage};
use crate::plan::{PlanError, StagePlan};
use crate::scene::Scene;

/// The camera of a scene.
pub fn scene_camera(scene: &Scene) -> Camera {
    Camera {
        width: scene.size.width,
        height: scene.size.height,
        fov_y_deg: scene.fov_y,
    }
}

/// Renders frame `n` of `scene` over `env` at `spp` samples per pixel.
pub fn render_frame(
    scene: &Scene,
    env: &HdrImage,
    n: u32,
    spp: u32,
) -> Result<FrameOutputs, PlanError> {
    let plan = StagePlan::for_scene(scene, spp);
    if plan.taa().is_some() {
        // A TAA frame depends on the frames before it: `render::SceneRenderer`
        // carries the history (`render_taa_frame`).
        return Err(PlanError::NoParameters {
            stage: "taa",
            what: "history (render TAA frames in order through render_taa_frame)",
        });
    }
    if plan.adaptation().is_some() {
        // An adapted frame depends on the frames before it too.
        return Err(PlanError::NoParameters {
            stage: "adaptation",
            what: "adapted luminance (render adapted frames in order through render_carried_frame)",
        });
    }
    let rotation = rotation_matrix(scene.rotation.axis, scene.angle(n));
    let hdr = lit(
        sphere::sphere(env, &scene_camera(scene), &rotation, spp),
        scene,
        n,
    );
    run_plan(&plan, hdr, &Pipeline::of_scene(scene))
}

/// The sphere's frame `n` under the scene's light at that frame
/// (`[[light]]`): every sample times the step's scale, after the average.
fn lit(hdr: LinearImage, scene: &Scene, n: u32) -> LinearImage {
    let light = scene.light(n);
    if light == 1.0 {
        return hdr;
    }
    hdr.map(|c| c.map(|v| v * light))
}

/// Frame `n` of a TAA scene at 1 spp: `sphere` at the frame's jitter,
/// `taa_sobel` and `taa` against `history` (None: a reset), then the rest of
/// the plan on the resolved frame. Returns the frame's outputs (`hdr` is the
/// `taa` output) and the next frame's history. The plan must be a TAA plan
/// (`StagePlan::for_scene(scene, 1)` of a scene with active TAA).
pub fn render_taa_frame(
    scene: &Scene,
    env: &HdrImage,
    n: u32,
    history: Option<&taa::TaaHistory>,
) -> Result<(FrameOutputs, taa::TaaHistory), PlanError> {
    let (out, history, _) = render_carried_frame(scene, env, n, 1, history, None)?;
    Ok((
        out,
        history.ok_or(PlanError::Incomplete { missing: "taa" })?,
    ))
}

/// Frame `n` of a scene whose frames depend on the frames before (TAA at 1
/// spp, eye adaptation): against the TAA `history` and what the frames
/// before were `adapted` to (each None: a reset, or none in the plan).
/// Returns the frame's outputs and what the next frame carries.
pub fn render_carried_frame(
    scene: &Scene,
    env: &HdrImage,
    n: u32,
    spp: u32,
    history: Option<&taa::TaaHistory>,
    adapted: Option<&adaptation::Adapted>,
) -> Result<
    (
        FrameOutputs,
        Option<taa::TaaHistory>,
        Option<adaptation::Adapted>,
    ),
    PlanError,
> {
    let plan = StagePlan::for_scene(scene, spp);
    let camera = scene_camera(scene);
    let rotation = rotation_matrix(scene.rotation.axis, scene.angle(n));
    let Some(params) = plan.taa() else {
        let hdr = lit(sphere::sphere(env, &camera, &rotation, spp), scene, n);
        let out = run_plan_adapted(&plan, hdr, &Pipeline::of_scene(scene), adapted)?;
        let next = out.adapted;
        return Ok((out, None, next));
    };
    let current = lit(
        sphere::sphere_jittered(env, &camera, &rotation, crate::conventions::taa_jitter(n)),
        scene,
        n,
    );
    let amount = plan
        .contains("taa_sobel")
        .then(|| taa_sobel::taa_sobel(&current));
    let previous = rotation_matrix(scene.rotation.axis, scene.angle(n.saturating_sub(1)));
    let frame = taa::TaaFrame {
        history,
        reprojection: taa::Reprojection::Rotation {
            camera,
            matrix: crate::conventions::reprojection(&previous, &rotation),
        },
    };
    let resolved = taa::taa(&current, amount.as_ref(), &frame, &params);
    let out = run_plan_adapted(&plan, resolved.output, &Pipeline::of_scene(scene), adapted)?;
    let next = out.adapted;
    Ok((out, Some(resolved.history), next))
}
