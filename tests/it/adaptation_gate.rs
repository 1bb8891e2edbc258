//! Histogram metering in the gate's renderer (lavapipe): the counting a
//! CPU adapter gets and the one a GPU gets, on the same scene frames.

use crate::adaptation::{curve_of, golden_root};
use tonegate::scene::Adaptation;

/// Histogram metering in the gate's renderer counts the same bins both
/// ways (by blocks, the CPU adapters' way, and by shared-memory tiles, the
/// GPUs'), so the two curves are equal bit for bit; a centre-weighted mask
/// is another curve.
#[test]
fn the_histogram_counts_the_same_by_blocks_and_by_tiles() {
    use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, ReductionMethod};
    use tonegate::render::{scene_environment, SceneRenderer};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap();
    let mut scene =
        tonegate::scene::Scene::load(&golden_root().join("scenes/interior-agx-adaptation.toml"))
            .unwrap();
    scene.adaptation = Some(Adaptation::default());
    let env = scene_environment(&scene).unwrap();
    let curve = |scene: &tonegate::scene::Scene, reduction| {
        let config = GpuConfig {
            reduction,
            ..GpuConfig::default()
        };
        let r = SceneRenderer::gpu(scene, &env, &ctx, config, 1).unwrap();
        curve_of(&r)
    };
    let blocks = curve(&scene, ReductionMethod::BlockPartials);
    let tiles = curve(&scene, ReductionMethod::Tree);
    assert_eq!(blocks, tiles);
    // It moves with the light (25 times brighter from frame 6).
    assert!(blocks[10] > blocks[5] * 2.0, "{blocks:?}");
    scene.adaptation = Some(Adaptation {
        mask: tonegate::scene::Mask::Centre,
        ..Adaptation::default()
    });
    let centre = curve(&scene, ReductionMethod::Tree);
    assert_eq!(centre, curve(&scene, ReductionMethod::BlockPartials));
    assert_ne!(centre, blocks);
    println!(
        "histogram: frame 0, 10, 23 adapted {:.5} {:.5} {:.5} (uniform), {:.5} {:.5} {:.5} (centre)",
        blocks[0], blocks[10], blocks[23], centre[0], centre[10], centre[23]
    );
}
