//! The GFS-VO pipeline: the stage loops that the services in `services/` run, the wire
//! payloads they exchange, their checkpoints, and the config every stage reads.
//!
//! **Why.** DESIGN.md: each stage is a separate process so that one can crash and be
//! restarted while the others go on; a service holds no algorithm and the algorithms
//! know nothing of processes. This crate is the thin layer in between: each stage is
//! `receive -> call the library -> publish` over [`gfs_ipc`] topics.
//!
//! **Model.** [`stages::run_stage`] runs one stage for a [`stages::StageContext`]
//! (settings, iceoryx2 node, stop request), as a process (`ipc::Service`) or a thread
//! (`local::Service`). Per-frame payloads are the fixed-layout structs of [`wire`];
//! keyframes and maps are bincode. Stages that hold state (source position, tracker,
//! mapper) checkpoint it into the run's [`state::StateDir`] after each step, so that a
//! restarted stage goes on where the killed one stopped. [`service`] is the whole `main`
//! of a stage executable.
#![warn(missing_docs)]

mod checks;
pub mod config;
pub mod map_files;
pub mod progress;
pub mod scheduling;
pub mod service;
pub mod stages;
pub mod state;
pub mod wire;

pub use config::{Config, ConfigError, PipelineConfig};
