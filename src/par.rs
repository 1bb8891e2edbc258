//! The CPU reference's data parallelism: rayon's parallel iterators with
//! the `reference` feature. Without it (a lean `embed` build, which
//! compiles the reference for the types the `ToneMapper` shares with it and
//! never runs it per pixel) the same calls run in sequence through std's
//! slice iterators, so the reference's code is written once.

#[cfg(feature = "reference")]
pub(crate) use rayon::prelude::*;

#[cfg(not(feature = "reference"))]
pub(crate) use sequential::{ParallelSlice, ParallelSliceMut};

#[cfg(not(feature = "reference"))]
mod sequential {
    /// rayon's `par_chunks`, in sequence.
    pub(crate) trait ParallelSlice<T> {
        fn par_chunks(&self, size: usize) -> std::slice::Chunks<'_, T>;
    }

    /// rayon's `par_iter_mut` and `par_chunks_mut`, in sequence.
    pub(crate) trait ParallelSliceMut<T> {
        fn par_iter_mut(&mut self) -> std::slice::IterMut<'_, T>;
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T>;
    }

    impl<T> ParallelSlice<T> for [T] {
        fn par_chunks(&self, size: usize) -> std::slice::Chunks<'_, T> {
            self.chunks(size)
        }
    }

    impl<T> ParallelSliceMut<T> for [T] {
        fn par_iter_mut(&mut self) -> std::slice::IterMut<'_, T> {
            self.iter_mut()
        }
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T> {
            self.chunks_mut(size)
        }
    }
}
