//! What a context has created on its device, counted as it is created: the
//! figure that shows whether a frame loop makes resources every frame (a
//! cache keyed by something that changes each frame does) or none once it
//! is warm (docs/embedding.md#what-a-frame-creates).

use std::sync::atomic::{AtomicU64, Ordering};

/// How many of each kind of GPU object a [`crate::gpu::ToneMapper`] (or any
/// tonegate context) has created since it was made. Differences between
/// two readings are what a stretch of frames created.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Created {
    /// Textures (intermediates, histories).
    pub textures: u64,
    /// Buffers (uniforms, statistics, staging).
    pub buffers: u64,
    /// Bind groups.
    pub bind_groups: u64,
    /// Compute and render pipelines compiled.
    pub pipelines: u64,
}

impl std::ops::Sub for Created {
    type Output = Created;

    /// What was created between two readings (`later - earlier`).
    fn sub(self, earlier: Created) -> Created {
        Created {
            textures: self.textures - earlier.textures,
            buffers: self.buffers - earlier.buffers,
            bind_groups: self.bind_groups - earlier.bind_groups,
            pipelines: self.pipelines - earlier.pipelines,
        }
    }
}

/// The running counts behind [`Created`], shared by the clones of a
/// context.
#[derive(Debug, Default)]
pub(crate) struct Counts {
    textures: AtomicU64,
    buffers: AtomicU64,
    bind_groups: AtomicU64,
    pipelines: AtomicU64,
}

/// Which count a creation adds to.
#[derive(Clone, Copy)]
pub(crate) enum Kind {
    Texture,
    Buffer,
    BindGroup,
    Pipeline,
}

impl Counts {
    pub(crate) fn add(&self, kind: Kind) {
        let counter = match kind {
            Kind::Texture => &self.textures,
            Kind::Buffer => &self.buffers,
            Kind::BindGroup => &self.bind_groups,
            Kind::Pipeline => &self.pipelines,
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn read(&self) -> Created {
        Created {
            textures: self.textures.load(Ordering::Relaxed),
            buffers: self.buffers.load(Ordering::Relaxed),
            bind_groups: self.bind_groups.load(Ordering::Relaxed),
            pipelines: self.pipelines.load(Ordering::Relaxed),
        }
    }
}
