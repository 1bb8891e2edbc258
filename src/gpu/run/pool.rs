//! Renderers kept between flat images on one device (the server's GPU
//! worker, and any caller tone-mapping many images): what makes the second
//! image of a size class cost an upload instead of a renderer.

use crate::gpu::{GpuConfig, GpuContext, GpuError, GpuInput, GpuRenderer};
use crate::image::HdrImage;
use crate::operators::Operator;
use crate::plan::StagePlan;
use crate::reference::Pipeline;
use crate::scene::{Bloom, Encoding, Grade};

/// What a kept renderer was built for: its textures' size class, its plan,
/// the parameters its uniforms and override constants hold, and the GPU
/// configuration. Two requests with equal keys can share the renderer.
#[derive(Clone, Debug, PartialEq)]
struct PoolKey {
    class: (u32, u32),
    plan: StagePlan,
    pipeline: OwnedPipeline,
    config: GpuConfig,
}

/// A [`Pipeline`]'s parameters, owned, for a key that outlives the request.
#[derive(Clone, Debug, PartialEq)]
struct OwnedPipeline {
    operator: Operator,
    bloom: Option<Bloom>,
    grade: Option<Grade>,
    encoding: Encoding,
}

impl OwnedPipeline {
    fn of(p: &Pipeline) -> OwnedPipeline {
        OwnedPipeline {
            operator: p.operator.clone(),
            bloom: p.bloom.cloned(),
            grade: p.grade.cloned(),
            encoding: p.encoding,
        }
    }
}

/// Renderers kept between images on one device (the server's GPU worker):
/// an image of a size class, plan, settings and configuration seen before
/// is uploaded into that renderer's input ([`GpuRenderer::reload`]) instead
/// of creating its textures, buffers and bind groups again. A renderer's
/// textures have its class's size ([`size_class`]) and it renders any image
/// of the class in their top-left corner. At most [`RendererPool::KEEP`]
/// renderers and [`RendererPool::KEEP_PIXELS`] pixels of textures are kept
/// (by default), the least recently used dropped first; a renderer over the
/// pixel budget alone is dropped once its image is done.
pub struct RendererPool<'a> {
    ctx: &'a GpuContext,
    /// (key, renderer), the most recently used last: a handful, searched
    /// in order.
    kept: Vec<(PoolKey, GpuRenderer<'a>)>,
    keep: usize,
    keep_pixels: u64,
    /// Whether renderers are made for size classes (else for exact sizes).
    classes: bool,
}

/// The size class of a `width`×`height` image on an adapter whose textures
/// are at most `limit` wide and tall: each side rounded up to a multiple of
/// a sixteenth of its next power of two, and of 64 at least. A class's side
/// is at most 12.5 % or 63 pixels longer than any image's in it; there are
/// eight classes per doubling of a side beyond 1024, and multiples of 64 up
/// to it (1920×1080 is in 1920×1152).
pub fn size_class(width: u32, height: u32, limit: u32) -> (u32, u32) {
    let side = |d: u32| {
        let power = d.max(1).checked_next_power_of_two().unwrap_or(1 << 31);
        let step = (power / 16).max(64);
        d.div_ceil(step).saturating_mul(step).min(limit).max(d)
    };
    (side(width), side(height))
}

impl<'a> RendererPool<'a> {
    pub const KEEP: usize = 4;
    /// Two 4096×2048 frames' worth: a renderer holds several full-frame
    /// textures (16 bytes a pixel each in f32), so this bounds the device
    /// memory kept idle to a few hundred MiB.
    pub const KEEP_PIXELS: u64 = 2 * 4096 * 2048;

    pub fn new(ctx: &'a GpuContext) -> Self {
        Self::with_limits(ctx, Self::KEEP, Self::KEEP_PIXELS)
    }

    /// Keeps at most `keep` renderers and `keep_pixels` pixels among them.
    pub fn with_limits(ctx: &'a GpuContext, keep: usize, keep_pixels: u64) -> Self {
        RendererPool {
            ctx,
            kept: Vec::new(),
            keep: keep.max(1),
            keep_pixels,
            classes: true,
        }
    }

    /// Renderers made for each image's exact size, not its class: for one
    /// image, where nothing is reused.
    pub fn exact_sizes(mut self) -> Self {
        self.classes = false;
        self
    }

    /// The pixels of the kept renderers' textures (their capacities).
    pub fn pixels(&self) -> u64 {
        self.kept.iter().map(|(_, r)| capacity_pixels(r)).sum()
    }

    /// Drops a renderer larger than the pixel budget on its own: it served
    /// its image and is not kept idle on the device.
    pub fn release_oversize(&mut self) {
        let budget = self.keep_pixels;
        self.kept.retain(|(_, r)| capacity_pixels(r) <= budget);
    }

    pub fn ctx(&self) -> &'a GpuContext {
        self.ctx
    }

    /// How many renderers are kept now.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }

    /// A renderer of `plan` for `img` with `pipeline` and `config`: a kept
    /// one of its size class reloaded with `img`, or a new one, kept after
    /// the least recently used ones it has no room beside were dropped
    /// (before it is created, so the device never holds more than the budget
    /// and the new one).
    pub fn renderer(
        &mut self,
        img: &HdrImage,
        plan: &StagePlan,
        pipeline: &Pipeline,
        config: GpuConfig,
    ) -> Result<&GpuRenderer<'a>, GpuError> {
        // An image too large for the adapter is refused before any kept
        // renderer is dropped to make room for it.
        self.ctx.check_frame(img.width, img.height)?;
        let exact = (img.width, img.height);
        let class = match self.classes {
            true => size_class(
                img.width,
                img.height,
                self.ctx.limits.max_texture_dimension_2d,
            ),
            false => exact,
        };
        // A class that the budget or the adapter cannot hold gives way to
        // the image's own size: kept if that fits the budget, else rendered
        // once and dropped (`release_oversize`).
        let pixels = |(w, h): (u32, u32)| w as u64 * h as u64;
        let fits =
            |(w, h)| pixels((w, h)) <= self.keep_pixels && self.ctx.check_frame(w, h).is_ok();
        let class = if fits(class) { class } else { exact };
        let key = PoolKey {
            class,
            plan: plan.clone(),
            pipeline: OwnedPipeline::of(pipeline),
            config,
        };
        if let Some(i) = self.kept.iter().position(|(k, _)| *k == key) {
            let (k, r) = self.kept.remove(i);
            if r.reload(img) {
                self.kept.push((k, r));
                return Ok(&self.kept[self.kept.len() - 1].1);
            }
        }
        let wanted = pixels(class);
        while !self.kept.is_empty()
            && (self.kept.len() >= self.keep || self.pixels() + wanted > self.keep_pixels)
        {
            self.kept.remove(0);
        }
        let r = GpuRenderer::with_capacity(
            self.ctx,
            plan.clone(),
            GpuInput::Flat(img),
            pipeline,
            config,
            class,
        )?;
        self.kept.push((key, r));
        Ok(&self.kept[self.kept.len() - 1].1)
    }
}

fn capacity_pixels(r: &GpuRenderer) -> u64 {
    let (w, h) = r.capacity();
    w as u64 * h as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_class_is_at_most_an_eighth_or_63_pixels_longer_on_a_side() {
        let limit = 16384;
        let mut classes = std::collections::BTreeSet::new();
        for d in 1..=limit {
            let (c, _) = size_class(d, 1, limit);
            assert!(c >= d && c <= limit, "{d} -> {c}");
            assert!(
                c as f64 <= (d as f64 * 1.125).max(d as f64 + 63.0),
                "{d} -> {c}"
            );
            // A class holds every size between its smaller neighbour and it.
            assert_eq!(size_class(c, 1, limit).0, c, "{d} -> {c}");
            classes.insert(c);
        }
        // Eight per doubling beyond 1024, multiples of 64 up to it.
        let octave = |lo: u32, hi: u32| classes.range(lo + 1..=hi).count();
        assert_eq!(octave(1024, 2048), 8);
        assert_eq!(octave(8192, 16384), 8);
        assert_eq!(octave(0, 1024), 16);
        assert_eq!(size_class(1000, 500, limit), (1024, 512));
        assert_eq!(size_class(1920, 1080, limit), (1920, 1152));
        assert_eq!(size_class(3840, 2160, limit), (3840, 2304));
        // Capped by the adapter's limit, never below the image.
        assert_eq!(size_class(8100, 10, 8192), (8192, 64));
        assert_eq!(size_class(8192, 8192, 8192), (8192, 8192));
    }
}
