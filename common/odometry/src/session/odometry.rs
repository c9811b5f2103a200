//! The sequential entry point: feed frames, get poses. The tracking half and the mapping
//! half run one after the other in the caller's thread and exchange the same messages as
//! the `tracker` and `mapper` services, so this path and the lockstep pipeline agree.

use crate::config::OdometryConfig;
use crate::frontend::features::{FeatureError, FrameFeatures};
use crate::loop_closing::LoopClosure;
use crate::map::Map;
use crate::map::manhattan::WorldManhattan;
use crate::map_file::{MapCamera, MapFileError, SavedMap, save_map};
use crate::session::final_trajectory::FrameAnchor;
use crate::session::{FramePose, LoadedMapUse, MappingSession, TrackingSession};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::FrameId;
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Matrix6, Rotation3};
use std::path::Path;
use std::time::{Duration, Instant};

/// Time spent on the last frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct OdometryTimings {
    /// Tracking (prediction, matching, pose optimisation, local-map tracking, recovery).
    pub tracking: Duration,
    /// Local mapping, when the frame became a keyframe.
    pub mapping: Option<Duration>,
    /// Relocalisation against the whole map in the mapping half (bag-of-words query and
    /// verification), when the frame was lost.
    pub relocalisation: Option<Duration>,
}

/// RGB-D visual odometry over point, line and Manhattan features.
pub struct Odometry {
    tracking: TrackingSession,
    mapping: MappingSession,
    timings: OdometryTimings,
    covariance: Option<Matrix6<f64>>,
}

impl Odometry {
    /// An odometry for an undistorted `camera` whose ORB pyramid has `levels` levels
    /// `scale_factor` apart; `grid` is the line grid of the line front end.
    pub fn new(
        config: OdometryConfig,
        camera: PinholeCamera,
        scale_factor: f64,
        levels: u8,
        grid: &GridConfig,
    ) -> Self {
        Self {
            mapping: MappingSession::new(&config, camera, scale_factor, levels),
            tracking: TrackingSession::new(config, camera, scale_factor, levels, grid),
            timings: OdometryTimings::default(),
            covariance: None,
        }
    }

    /// The global map (for inspection and tests).
    pub fn map(&self) -> &Map {
        self.mapping.map()
    }

    /// Takes over a map saved by an earlier run, before the first frame: mapping goes
    /// on in it, or with `use_.localise` each frame is only tracked against it. The
    /// first frame is looked for around the keyframe nearest to `use_.initial_pose`,
    /// else in the whole map; poses are in the map's frame.
    pub fn start_from(&mut self, saved: SavedMap, use_: &LoadedMapUse) {
        self.mapping.start_from(saved, use_.localise);
        let centre = use_
            .initial_pose
            .and_then(|pose| self.mapping.nearest_keyframe(&pose));
        let map = match centre {
            Some(kf) => self.mapping.update_around(kf).map,
            None => Map::default(),
        };
        let manhattan = self.mapping.manhattan().clone();
        self.tracking.start_on_map(map, manhattan, centre, use_);
    }

    /// Writes the global map to a map file (atomically); returns the bytes written.
    ///
    /// # Errors
    /// [`MapFileError`] naming the file.
    pub fn save_map(&self, path: &Path, camera: &MapCamera) -> Result<u64, MapFileError> {
        save_map(path, camera, self.mapping.map(), self.mapping.manhattan())
    }

    /// Keyframes made since the start (0 in localisation).
    pub fn keyframes_added(&self) -> usize {
        self.mapping.keyframes_added()
    }

    /// Lost frames found again in the whole map since the start (the first frame on a
    /// loaded map without a pose hint among them).
    pub fn relocalisations(&self) -> usize {
        self.mapping.relocalisations()
    }

    /// The tracking half (for inspection and tests: its map is the neighbourhood the
    /// mapping half sent last).
    pub fn tracking(&self) -> &TrackingSession {
        &self.tracking
    }

    /// The loops closed so far.
    pub fn loops(&self) -> &[LoopClosure] {
        self.mapping.closures()
    }

    /// The loop corrections so far (REP 105 `map -> odom`): a frame's map pose is
    /// `map_from_odom * FramePose::world_from_camera`.
    pub fn map_from_odom(&self) -> &Isometry3<f64> {
        self.tracking.map_from_odom()
    }

    /// The anchor of the frame just processed (whose published pose is `pose`), or
    /// `None` before the first keyframe.
    pub fn anchor(&self, pose: &FramePose) -> Option<FrameAnchor> {
        self.tracking.anchor(pose)
    }

    /// The covariance of the last frame's pose as the tracker published it (the
    /// pipeline's `pose` topic carries the same), `None` when it was not tracked.
    pub fn pose_covariance(&self) -> Option<Matrix6<f64>> {
        self.covariance
    }

    /// Timings of the last processed frame.
    pub fn timings(&self) -> &OdometryTimings {
        &self.timings
    }

    /// The predicted rotation from the last frame to the next (`current_from_previous`),
    /// which keeps the Manhattan axes' identity in the front end.
    pub fn predicted_rotation(&self) -> Option<Rotation3<f64>> {
        self.tracking.predicted_rotation()
    }

    /// The world Manhattan axes, once seen.
    pub fn manhattan(&self) -> &WorldManhattan {
        self.tracking.manhattan()
    }

    /// The pose of a frame whose images could not be read: the motion-model prediction,
    /// flagged [`crate::TrackingStatus::Predicted`], so that the trajectory keeps one
    /// line per input frame.
    pub fn skip(&mut self, id: FrameId, timestamp: gfs_core::stamp::Stamp) -> FramePose {
        self.timings = OdometryTimings::default();
        self.covariance = None;
        self.tracking.skip(id, timestamp)
    }

    /// Adds an IMU sample for the frames after it (see [`TrackingSession::push_imu`]).
    pub fn push_imu(&mut self, sample: gfs_inertial::ImuSample) -> gfs_inertial::Pushed {
        self.tracking.push_imu(sample)
    }

    /// Processes the next frame and returns its pose. Always produces a pose: an
    /// untracked frame gets the motion-model prediction, flagged.
    ///
    /// # Errors
    /// [`FeatureError`] when the feature vectors of the frame do not line up; the frame
    /// is then not used and the caller may go on with the next one.
    pub fn process(&mut self, features: FrameFeatures) -> Result<FramePose, FeatureError> {
        let start = Instant::now();
        let output = self.tracking.process(features)?;
        let tracked = start.elapsed();
        self.covariance = output.covariance;
        let mut pose = output.pose;
        let mut mapping = None;
        if let Some(request) = output.keyframe {
            let mapping_start = Instant::now();
            let update = self.mapping.insert(request);
            self.tracking.apply(update);
            mapping = Some(mapping_start.elapsed());
        }
        let mut relocalisation = None;
        if let Some(request) = output.relocalisation {
            let relocalisation_start = Instant::now();
            let answer = self.mapping.relocalise(&request);
            relocalisation = Some(relocalisation_start.elapsed());
            let update = answer.to_owned();
            self.tracking.apply(update);
            if let Some(found) = self.tracking.take_relocalised() {
                pose = found;
            }
        }
        self.timings = OdometryTimings {
            tracking: tracked,
            mapping,
            relocalisation,
        };
        Ok(pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Scene, camera, pose};

    #[test]
    fn a_scripted_walk_is_tracked_frame_by_frame() {
        let mut odometry = Odometry::new(
            OdometryConfig::default(),
            camera(),
            1.2,
            8,
            &GridConfig::default(),
        );
        let scene = Scene::new(200, 20);
        let mut mapped = 0;
        for k in 0..40u64 {
            let truth = pose(0.008 * k as f64, (0.15 * k as f64).to_radians());
            let out = odometry
                .process(scene.features(k, &truth))
                .expect("consistent features");
            assert!(out.status.is_tracked(), "frame {k}");
            let error = out.world_from_camera * truth;
            assert!(error.translation.vector.norm() < 1e-3, "frame {k}: {error}");
            mapped += usize::from(odometry.timings().mapping.is_some());
        }
        assert!(mapped >= 2, "{mapped} keyframes");
        assert_eq!(odometry.map().keyframe_count(), mapped);
        let skipped = odometry.skip(FrameId(40), crate::testing::frame_stamp(40));
        assert_eq!(skipped.status, crate::TrackingStatus::Predicted);
    }
}
