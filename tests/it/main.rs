//! tonegate's integration tests, linked once: each file here was its own
//! test binary, and every one of them linked wgpu, naga, tokio, axum,
//! SQLite, PostgreSQL's client, FLIP's C++ and exr again. Shared fixtures
//! (a seeded history, a PostgreSQL server, a served HTTP port) are in
//! `common/`. `io_validation` installs this binary's global allocator (a
//! per-thread record of the largest allocation); the test that counts every
//! byte a decode holds at its peak needs an allocator no other test shares
//! and is its own binary, `tests/exr_allocation.rs`.

mod common;

mod aces2;
mod adaptation;
mod adaptation_bevy;
mod adaptation_cameras;
mod adaptation_gate;
mod adaptation_scenes;
mod adaptation_white;
mod adapters;
mod alerts;
mod alerts_frames;
mod alerts_stuck;
mod api;
mod architecture;
mod chaos;
mod check;
mod commands_doc;
mod compare_cli;
mod dashboard;
mod display;
mod docs_examples;
mod fleet;
mod frames;
mod frames_api;
mod frames_cli;
mod frames_decisions;
mod frames_rules;
mod frames_store;
mod fuzz_regressions;
mod golden;
mod gpu;
mod gpu_metrics;
mod history;
mod hostile;
mod hostile_runs;
mod io_exr;
mod io_roundtrip;
mod io_validation;
mod metrics_perceptual;
mod metrics_skimage;
mod objects;
mod openapi;
mod operators;
mod pfstmo;
mod postgres;
mod random_params;
mod slow_clients;
mod store_chaos;
mod store_faults;
mod stress;
mod taa;
mod tone_mapper;
mod tonemap_cli;
mod tradeoff;
mod triage_page;
