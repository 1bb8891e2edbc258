//! The context's pipeline caches: compute and render pipelines, each under
//! a [`PipelineKey`] that names everything its code depends on, kept for
//! the [`PIPELINE_CACHE_LIMIT`] variants used last. A new variant past the
//! limit drops the one used longest ago (only the cache's handle: a
//! renderer holding that pipeline keeps it), never the whole cache, so a
//! server that sees a new image size now and then does not recompile the
//! pipelines every frame of its other sizes uses.

use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

/// What a pipeline is compiled from.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PipelineKey {
    pub kind: PipelineKind,
    /// The intermediate format the shader's `HDR_FORMAT` names.
    pub format: crate::gpu::HdrFormat,
    /// The override constants, by name, values as f64 bits.
    pub constants: Vec<(String, u64)>,
    /// The operator's WGSL module, for a stage that includes one: by its
    /// text, so two registrations of the same module share pipelines.
    pub operator: Option<&'static str>,
}

/// The shader entry a pipeline runs.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) enum PipelineKind {
    /// A compute pipeline: the stage's shader (`shaders/<stage>.wgsl`) and
    /// its entry point.
    Compute { stage: String, entry: String },
    /// The fullscreen render pass into a target of `target`'s format.
    Render { target: wgpu::TextureFormat },
}

impl PipelineKey {
    /// The key of a pipeline with `constants` (their f64 values by bits).
    pub(crate) fn new(
        kind: PipelineKind,
        format: crate::gpu::HdrFormat,
        constants: &[(&str, f64)],
        operator: Option<&'static str>,
    ) -> PipelineKey {
        PipelineKey {
            kind,
            format,
            constants: constants
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.to_bits()))
                .collect(),
            operator,
        }
    }
}

/// Distinct variants a cache keeps. Override constants include image
/// sizes, so a server seeing many sizes would otherwise grow without end.
pub(crate) const PIPELINE_CACHE_LIMIT: usize = 256;

/// A pipeline being compiled or compiled: the first thread to ask for a
/// variant compiles it, the others asking meanwhile wait for it.
pub(crate) type Slot<P> = Arc<OnceLock<P>>;

/// Compiled pipelines of one kind (`P`: compute or render), by key, the
/// least recently used dropped past the limit.
pub(crate) struct PipelineCache<P> {
    entries: HashMap<PipelineKey, (Slot<P>, u64)>,
    limit: usize,
    /// Ticks at each lookup: an entry's last use.
    clock: u64,
}

impl<P> Default for PipelineCache<P> {
    fn default() -> PipelineCache<P> {
        PipelineCache::with_limit(PIPELINE_CACHE_LIMIT)
    }
}

impl<P> PipelineCache<P> {
    pub(crate) fn with_limit(limit: usize) -> PipelineCache<P> {
        PipelineCache {
            entries: HashMap::new(),
            limit: limit.max(1),
            clock: 0,
        }
    }

    /// The slot of `key`, marked used now; a new key past the limit
    /// takes the place of the entry used longest ago.
    pub(crate) fn slot(&mut self, key: PipelineKey) -> Slot<P> {
        self.clock += 1;
        let now = self.clock;
        if let Some((slot, used)) = self.entries.get_mut(&key) {
            *used = now;
            return slot.clone();
        }
        if self.entries.len() >= self.limit {
            let oldest = self
                .entries
                .iter()
                .min_by_key(|(_, (_, used))| *used)
                .map(|(k, _)| k.clone());
            if let Some(oldest) = oldest {
                self.entries.remove(&oldest);
            }
        }
        let slot = Slot::default();
        self.entries.insert(key, (slot.clone(), now));
        slot
    }

    /// How many variants it keeps.
    pub(crate) fn len(&self) -> usize {
        self.entries.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(entry: &str) -> PipelineKey {
        let kind = PipelineKind::Compute {
            stage: "tonemap".into(),
            entry: entry.into(),
        };
        PipelineKey::new(kind, crate::gpu::HdrFormat::Rgba32Float, &[], None)
    }

    #[test]
    fn past_the_limit_the_variant_used_longest_ago_goes_and_no_other() {
        let mut cache: PipelineCache<u32> = PipelineCache::with_limit(3);
        for (i, e) in ["a", "b", "c"].into_iter().enumerate() {
            let _ = cache.slot(key(e)).set(i as u32);
        }
        // `a` used again: `b` is now the oldest.
        assert_eq!(cache.slot(key("a")).get(), Some(&0));
        let _ = cache.slot(key("d")).set(3);
        assert_eq!(cache.len(), 3);
        assert_eq!(cache.slot(key("a")).get(), Some(&0), "a was kept");
        assert_eq!(cache.slot(key("c")).get(), Some(&2), "c was kept");
        assert_eq!(cache.slot(key("d")).get(), Some(&3));
        // `b` was dropped: asked again, it is a new, empty slot (and it
        // takes the place of `a`, now the oldest).
        assert_eq!(cache.slot(key("b")).get(), None);
        assert_eq!(cache.len(), 3);
    }

    #[test]
    fn keys_differ_by_kind_constants_and_operator_text() {
        let render = PipelineKind::Render {
            target: wgpu::TextureFormat::Bgra8UnormSrgb,
        };
        let f = crate::gpu::HdrFormat::Rgba32Float;
        let a = PipelineKey::new(render.clone(), f, &[("GAIN", 1.0)], None);
        assert_ne!(
            a,
            PipelineKey::new(render.clone(), f, &[("GAIN", 2.0)], None)
        );
        assert_ne!(a, key("main"));
        // The operator by its text, not where it lives.
        let text = String::from("fn curve() {}");
        let leaked: &'static str = Box::leak(text.clone().into_boxed_str());
        let other: &'static str = Box::leak(text.into_boxed_str());
        assert_eq!(
            PipelineKey::new(render.clone(), f, &[], Some(leaked)),
            PipelineKey::new(render, f, &[], Some(other))
        );
    }
}
