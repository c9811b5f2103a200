//! The sequential entry point: feed frames, get poses. Tracking and local mapping run
//! one after the other in the caller's thread (the pipeline runs them as two services).

use crate::config::OdometryConfig;
use crate::frame::{FeatureError, FrameFeatures};
use crate::keyframe_policy::needs_keyframe;
use crate::manhattan::WorldManhattan;
use crate::map::Map;
use crate::mapper::Mapper;
use crate::relocalise::relocalise;
use crate::status::TrackingStatus;
use crate::tracker::{TrackedFrame, Tracker};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{FrameId, KeyFrameId};
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Rotation3};
use std::time::{Duration, Instant};

/// Inliers a relocalisation needs (ORB-SLAM2 asks 50 after its final optimisation).
const RELOCALISATION_MIN_INLIERS: usize = 40;

/// The pose of one frame, as written to the trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePose {
    /// The frame.
    pub id: FrameId,
    /// Its capture time, seconds.
    pub timestamp: f64,
    /// `world_from_camera` (T_wc).
    pub world_from_camera: Isometry3<f64>,
    /// How the pose was obtained.
    pub status: TrackingStatus,
}

/// Time spent on the last frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct OdometryTimings {
    /// Tracking (prediction, matching, pose optimisation, local-map tracking, recovery).
    pub tracking: Duration,
    /// Local mapping, when the frame became a keyframe.
    pub mapping: Option<Duration>,
}

/// RGB-D visual odometry over point, line and Manhattan features.
pub struct Odometry {
    config: OdometryConfig,
    camera: PinholeCamera,
    tracker: Tracker,
    mapper: Mapper,
    map: Map,
    manhattan: WorldManhattan,
    initialised: bool,
    frames_since_keyframe: u32,
    lost_streak: u32,
    timings: OdometryTimings,
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
        let tracker = Tracker::new(config.tracking.clone(), camera, scale_factor, levels, grid);
        let mapper = Mapper::new(
            config.mapping.clone(),
            config.keyframes.clone(),
            camera,
            *tracker.scale(),
            config.tracking.close_depth_m,
            config.tracking.use_lines,
        );
        Self {
            manhattan: WorldManhattan::new(config.tracking.use_manhattan),
            map: Map::default(),
            initialised: false,
            frames_since_keyframe: 0,
            lost_streak: 0,
            timings: OdometryTimings::default(),
            tracker,
            mapper,
            config,
            camera,
        }
    }

    /// The map (for inspection and tests).
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// Timings of the last processed frame.
    pub fn timings(&self) -> &OdometryTimings {
        &self.timings
    }

    /// The predicted rotation from the last frame to the next (`current_from_previous`),
    /// which keeps the Manhattan axes' identity in the front end.
    pub fn predicted_rotation(&self) -> Option<Rotation3<f64>> {
        self.tracker
            .velocity()
            .map(|v| v.rotation.to_rotation_matrix())
    }

    /// The pose of a frame whose images could not be read: the motion-model prediction,
    /// flagged [`TrackingStatus::Predicted`], so that the trajectory keeps one line per
    /// input frame.
    pub fn skip(&mut self, id: FrameId, timestamp: f64) -> FramePose {
        let camera_from_world = self.tracker.predict().unwrap_or_else(Isometry3::identity);
        self.tracker.finish_frame(TrackedFrame {
            features: FrameFeatures {
                id,
                timestamp,
                ..FrameFeatures::default()
            },
            camera_from_world,
            status: TrackingStatus::Predicted,
            point_ids: Vec::new(),
            line_ids: Vec::new(),
            inliers: Default::default(),
        });
        self.timings = OdometryTimings::default();
        FramePose {
            id,
            timestamp,
            world_from_camera: camera_from_world.inverse(),
            status: TrackingStatus::Predicted,
        }
    }

    /// The world Manhattan axes, once seen.
    pub fn manhattan(&self) -> &WorldManhattan {
        &self.manhattan
    }

    /// Processes the next frame and returns its pose. Always produces a pose: an
    /// untracked frame gets the motion-model prediction, flagged.
    ///
    /// # Errors
    /// [`FeatureError`] when the feature vectors of the frame do not line up; the frame
    /// is then not used and the caller may go on with the next one.
    pub fn process(&mut self, features: FrameFeatures) -> Result<FramePose, FeatureError> {
        features.validate()?;
        let start = Instant::now();
        let mut mapping = None;
        let mut refined = None;
        let mut frame = if self.initialised {
            self.tracker.track(&mut self.map, features)
        } else {
            self.try_initialise(features)
        };
        if self.initialised && !frame.status.is_tracked() {
            self.recover(&mut frame);
        } else {
            self.lost_streak = 0;
        }
        if frame.status.is_tracked() && self.initialised {
            if let Some(axes) = &frame.features.manhattan {
                self.manhattan
                    .observe(&frame.camera_from_world.inverse(), axes);
            }
            self.frames_since_keyframe += 1;
            if needs_keyframe(
                &self.config.keyframes,
                &self.map,
                &frame,
                self.tracker.reference(),
                self.frames_since_keyframe,
                self.config.tracking.close_depth_m,
            ) {
                let mapping_start = Instant::now();
                let kf = self.insert_keyframe(&frame);
                refined = self.map.keyframe(kf).map(|k| k.camera_from_world);
                mapping = Some(mapping_start.elapsed());
            }
        }
        tracing::debug!(
            frame = %frame.features.id,
            status = %frame.status,
            points = frame.inliers.points,
            lines = frame.inliers.lines,
            keyframe = mapping.is_some(),
            keyframes = self.map.keyframe_count(),
            "tracked"
        );
        let total = start.elapsed();
        self.timings = OdometryTimings {
            tracking: total - mapping.unwrap_or_default(),
            mapping,
        };
        // The local BA refined the new keyframe's pose together with the map it just
        // moved: the frame takes that pose, and so does the next prediction, as
        // ORB-SLAM2 places its last frame relative to its reference keyframe
        // (`Tracking::UpdateLastFrame`).
        let camera_from_world = refined.unwrap_or(frame.camera_from_world);
        let pose = FramePose {
            id: frame.features.id,
            timestamp: frame.features.timestamp,
            world_from_camera: camera_from_world.inverse(),
            status: frame.status,
        };
        self.tracker.finish_frame(frame);
        if refined.is_some() {
            self.tracker.correct_last_pose(camera_from_world);
        }
        Ok(pose)
    }

    /// Starts the map on the first frame with enough keypoints with depth; the world
    /// frame is that camera's (or, after a reset, the predicted pose).
    fn try_initialise(&mut self, features: FrameFeatures) -> TrackedFrame {
        let with_depth = features.keypoints.iter().filter(|k| k.depth > 0.0).count();
        let pose = self.tracker.predict().unwrap_or_else(Isometry3::identity);
        let ready = with_depth >= self.config.tracking.min_initial_points;
        let frame = TrackedFrame {
            point_ids: vec![None; features.keypoints.len()],
            line_ids: vec![None; features.lines.len()],
            camera_from_world: pose,
            status: if ready {
                TrackingStatus::Tracked
            } else {
                TrackingStatus::Predicted
            },
            inliers: Default::default(),
            features,
        };
        if ready {
            self.insert_keyframe(&frame);
            self.initialised = true;
        }
        frame
    }

    /// Relocalises a lost frame against the map; after too many lost frames, starts a
    /// new local map at the predicted pose so that the trajectory continues in the same
    /// world frame.
    fn recover(&mut self, frame: &mut TrackedFrame) {
        self.lost_streak += 1;
        let seed = frame.features.id.0;
        if let Some(found) = relocalise(
            &self.map,
            &frame.features,
            &self.camera,
            RELOCALISATION_MIN_INLIERS,
            seed,
        ) {
            frame.camera_from_world = found.camera_from_world;
            frame.point_ids = found.point_ids;
            frame.inliers.points = found.inliers;
            frame.status = TrackingStatus::Relocalised;
            self.lost_streak = 0;
            return;
        }
        if self.lost_streak >= self.config.tracking.frames_before_new_map {
            tracing::warn!(frame = %frame.features.id, "tracking lost: starting a new local map at the predicted pose");
            for kf in self.map.keyframe_ids() {
                self.map.remove_keyframe(kf);
            }
            self.initialised = false;
            self.lost_streak = 0;
            let features = std::mem::take(&mut frame.features);
            let restarted = self.try_initialise(features);
            frame.features = restarted.features;
            frame.point_ids = restarted.point_ids;
            frame.line_ids = restarted.line_ids;
        }
    }

    fn insert_keyframe(&mut self, frame: &TrackedFrame) -> KeyFrameId {
        let kf = self
            .mapper
            .add_keyframe(&mut self.map, frame, &mut self.manhattan);
        self.tracker.set_reference(kf);
        self.frames_since_keyframe = 0;
        kf
    }
}
