//! The stage loops. Each is `receive -> call the library -> publish` over gfs-ipc topics,
//! generic over the iceoryx2 service variant so that the same code runs as a process
//! (`ipc::Service`, the services in `services/`) or as a thread (`local::Service`,
//! `gfsvo run --mode threads`).

mod bag_source;
mod context;
pub mod imu;
mod join;
mod lines;
mod loop_closing;
mod mapper;
mod planes;
mod points;
pub mod ros2_frames;
mod source;
mod tracker;

pub use context::{StageContext, StageError, StageSettings};
pub use lines::run as run_lines;
pub use loop_closing::run as run_loop;
pub use mapper::{last_saved_map, run as run_mapper};
pub use planes::run as run_planes;
pub use points::run as run_points;
pub use source::run as run_source;
pub use tracker::run as run_tracker;

use crate::config::Config;
use gfs_ipc::{Service, Stage};

/// The stages a run with `config` starts: every one, the loop stage only with loop
/// closing on.
pub fn stages_to_run(config: &Config) -> Vec<Stage> {
    let loops = config.odometry().loop_closing.enabled;
    Stage::ALL
        .into_iter()
        .filter(|s| *s != Stage::Loop || loops)
        .collect()
}

/// Runs `stage` until it is told to stop.
///
/// # Errors
/// [`StageError`] when the stage cannot start (config, dataset, topics) or its
/// transport fails; the supervisor then restarts it.
pub fn run_stage<S: Service>(stage: Stage, ctx: &StageContext<S>) -> Result<(), StageError> {
    match stage {
        Stage::Source => run_source(ctx),
        Stage::Points => run_points(ctx),
        Stage::Lines => run_lines(ctx),
        Stage::Planes => run_planes(ctx),
        Stage::Tracker => run_tracker(ctx),
        Stage::Mapper => run_mapper(ctx),
        Stage::Loop => run_loop(ctx),
    }
}
