//! The device: which adapter (`adapters`, the choice by backend and name;
//! `listing`, what `tonegate adapters` prints), what it can and cannot do
//! (`capability`, `probe`), its validation layer's messages as errors
//! (`validation`), and the context every stage runs on (`context`: the
//! device and queue, the pipeline caches, the frame-size checks; `created`,
//! what it has created, counted).

pub mod adapters;
pub mod capability;
pub mod context;
pub(in crate::gpu) mod created;
pub mod listing;
pub(in crate::gpu) mod pipelines;
pub(in crate::gpu) mod probe;
pub mod validation;
