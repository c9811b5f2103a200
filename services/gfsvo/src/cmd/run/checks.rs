//! What `gfsvo run` checks before any work: its arguments, and that no other run writes
//! into its output folder.

use super::RunArgs;
use crate::CliResult;
use gfs_dataset::Trajectory;
use gfs_ipc::FileLock;
use gfs_odometry::{FramePose, TrackingStatus};
use std::path::Path;

/// The lock a run holds on its output folder while it lives.
const OUT_LOCK: &str = ".gfsvo-run.lock";

/// Rejects arguments that cannot give a run: no frame, a rate that is not a rate.
///
/// # Errors
/// Naming the flag and the value.
pub fn check_args(args: &RunArgs) -> CliResult {
    if args.frames == Some(0) {
        return Err("--frames 0: a run needs at least one frame".into());
    }
    if let Some(rate) = args.max_rate
        && !(rate.is_finite() && rate > 0.0)
    {
        return Err(
            format!("--max-rate {rate}: must be a positive number of frames per second").into(),
        );
    }
    Ok(())
}

/// Creates the output folder and locks it for this run.
///
/// # Errors
/// Naming the folder when it cannot be created, or when another live run holds it.
pub fn lock_out(out: &Path) -> CliResult<FileLock> {
    std::fs::create_dir_all(out)
        .map_err(|e| format!("cannot create the output folder {}: {e}", out.display()))?;
    let path = out.join(OUT_LOCK);
    match FileLock::try_acquire(&path) {
        Ok(Ok(lock)) => Ok(lock),
        Ok(Err(holder)) => Err(format!(
            "output folder {} is in use by {holder} (another gfsvo run): pick another --out",
            out.display()
        )
        .into()),
        Err(e) => Err(format!("cannot lock the output folder {}: {e}", path.display()).into()),
    }
}

/// The poses the tracker estimated (every status but `predicted`), the only ones the
/// ATE is computed over.
///
/// # Errors
/// When no frame was tracked: the run produced nothing but guesses.
pub fn tracked_trajectory(poses: &[FramePose], out: &Path) -> CliResult<Trajectory> {
    let trajectory = tracked_poses(poses);
    if trajectory.is_empty() {
        return Err(format!(
            "no frame of {} was tracked (every pose is predicted; {}/status.txt): are the \
             images readable and do the camera and depth tables fit the dataset?",
            poses.len(),
            out.display()
        )
        .into());
    }
    Ok(trajectory)
}

/// The poses of every status but `predicted`, as a trajectory (possibly empty).
pub fn tracked_poses(poses: &[FramePose]) -> Trajectory {
    let mut trajectory = Trajectory::new();
    for pose in poses
        .iter()
        .filter(|p| p.status != TrackingStatus::Predicted)
    {
        trajectory.push(pose.timestamp, pose.world_from_camera);
    }
    trajectory
}
