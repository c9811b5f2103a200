//! The tracking half of the odometry (the `tracker` service): tracks every frame against
//! its copy of the map, recovers when lost, decides keyframes and asks the mapping half
//! for them, and takes in the maps the mapping half sends back.

use super::messages::SightingCount;
use super::messages::{KeyFrameRequest, MapUpdate};
use super::sightings::{SightingBaseline, apply_sightings};
use crate::config::OdometryConfig;
use crate::frame::{FeatureError, FrameFeatures};
use crate::keyframe_policy::needs_keyframe;
use crate::manhattan::WorldManhattan;
use crate::map::Map;
use crate::motion::MotionModel;
use crate::relocalise::relocalise;
use crate::status::TrackingStatus;
use crate::tracker::{TrackedFrame, Tracker};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{FrameId, KeyFrameId, MapLineId, MapPointId};
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Rotation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// Inliers a relocalisation needs (ORB-SLAM2 asks 50 after its final optimisation).
const RELOCALISATION_MIN_INLIERS: usize = 40;

/// The pose of one frame, as written to the trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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

/// A tracked frame's pose, and the keyframe request when it should become one.
#[derive(Debug)]
pub struct TrackOutput {
    /// The pose (before local mapping refines it, when it becomes a keyframe).
    pub pose: FramePose,
    /// Send this to the mapping half, then hand its answer to
    /// [`TrackingSession::apply`].
    pub keyframe: Option<KeyFrameRequest>,
    /// Covariance of the pose from its optimisation (`gfs_optim::PoseResult::covariance`:
    /// camera-frame translation then rotation); `None` for a predicted pose.
    pub covariance: Option<nalgebra::Matrix6<f64>>,
}

/// What a restarted tracker needs to go on where the old one stopped (the map comes
/// from the mapper).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct TrackingCheckpoint {
    /// The last frame processed, with its features and landmark links.
    pub last: Option<TrackedFrame>,
    /// The motion model.
    pub motion: MotionModel,
    /// Point sightings counted since the last map arrived (the mapper culls on them).
    pub point_sightings: Vec<SightingCount<MapPointId>>,
    /// Line sightings counted since the last map arrived.
    pub line_sightings: Vec<SightingCount<MapLineId>>,
    /// The reference keyframe.
    pub reference: Option<KeyFrameId>,
    /// Whether a map was started.
    pub initialised: bool,
    /// Frames since the last keyframe.
    pub frames_since_keyframe: u32,
    /// Consecutive lost frames.
    pub lost_streak: u32,
    /// The last keyframe request number used.
    pub last_request: u64,
    /// The request the map tracked against answered.
    pub map_seq: u64,
    /// The world Manhattan axes.
    pub manhattan: WorldManhattan,
}

/// Tracks frames against a copy of the map that the mapping half keeps up to date.
pub struct TrackingSession {
    config: OdometryConfig,
    camera: PinholeCamera,
    tracker: Tracker,
    map: Map,
    manhattan: WorldManhattan,
    sightings: SightingBaseline,
    initialised: bool,
    frames_since_keyframe: u32,
    lost_streak: u32,
    last_request: u64,
    pending: Option<(u64, FrameId)>,
    reset_owed: bool,
    map_seq: u64,
}

impl TrackingSession {
    /// A tracking half for an undistorted `camera` whose ORB pyramid has `levels` levels
    /// `scale_factor` apart; `grid` is the line grid of the line front end.
    pub fn new(
        config: OdometryConfig,
        camera: PinholeCamera,
        scale_factor: f64,
        levels: u8,
        grid: &GridConfig,
    ) -> Self {
        Self {
            tracker: Tracker::new(config.tracking.clone(), camera, scale_factor, levels, grid),
            manhattan: WorldManhattan::new(config.tracking.use_manhattan),
            map: Map::default(),
            sightings: SightingBaseline::default(),
            initialised: false,
            frames_since_keyframe: 0,
            lost_streak: 0,
            last_request: 0,
            pending: None,
            reset_owed: false,
            map_seq: 0,
            config,
            camera,
        }
    }

    /// The map the tracker tracks against.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The world Manhattan axes as the tracker knows them.
    pub fn manhattan(&self) -> &WorldManhattan {
        &self.manhattan
    }

    /// The predicted rotation from the last frame to the next (`current_from_previous`),
    /// which keeps the Manhattan axes' identity in the front end.
    pub fn predicted_rotation(&self) -> Option<Rotation3<f64>> {
        self.predicted_quaternion().map(|q| q.to_rotation_matrix())
    }

    /// [`Self::predicted_rotation`] as the motion model holds it (what the tracker
    /// sends, so that the planes stage converts it exactly as the in-process path).
    pub fn predicted_quaternion(&self) -> Option<UnitQuaternion<f64>> {
        self.tracker.velocity().map(|v| v.rotation)
    }

    /// The keyframe request still waiting for its map (number and frame), if any.
    pub fn pending_request(&self) -> Option<(u64, FrameId)> {
        self.pending
    }

    /// True when the next frame cannot be tracked before the pending request's map
    /// arrives: the map is still empty.
    pub fn needs_map(&self) -> bool {
        self.pending.is_some() && self.map.keyframe_count() == 0
    }

    /// The pose of a frame whose features are missing: the motion-model prediction,
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
        FramePose {
            id,
            timestamp,
            world_from_camera: camera_from_world.inverse(),
            status: TrackingStatus::Predicted,
        }
    }

    /// Tracks the next frame. Always produces a pose: an untracked frame gets the
    /// motion-model prediction, flagged.
    ///
    /// # Errors
    /// [`FeatureError`] when the feature vectors of the frame do not line up; the frame
    /// is then not used and the caller may go on with the next one.
    pub fn process(&mut self, features: FrameFeatures) -> Result<TrackOutput, FeatureError> {
        features.validate()?;
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
        let tracked = frame.status.is_tracked();
        if tracked {
            if let Some(axes) = &frame.features.manhattan {
                self.manhattan
                    .observe(&frame.camera_from_world.inverse(), axes);
            }
            self.frames_since_keyframe += 1;
        }
        let wants_keyframe = if !self.initialised {
            // A frame that starts a map is its first keyframe.
            self.initialised = tracked;
            tracked
        } else {
            tracked
                && self.pending.is_none()
                && needs_keyframe(
                    &self.config.keyframes,
                    &self.map,
                    &frame,
                    self.tracker.reference(),
                    self.frames_since_keyframe,
                    self.config.tracking.close_depth_m,
                )
        };
        tracing::debug!(
            frame = %frame.features.id,
            status = %frame.status,
            points = frame.inliers.points,
            lines = frame.inliers.lines,
            keyframe = wants_keyframe,
            keyframes = self.map.keyframe_count(),
            "tracked"
        );
        let pose = FramePose {
            id: frame.features.id,
            timestamp: frame.features.timestamp,
            world_from_camera: frame.camera_from_world.inverse(),
            status: frame.status,
        };
        let keyframe = wants_keyframe.then(|| self.request_keyframe(&frame));
        let covariance = tracked.then(|| self.tracker.pose_covariance()).flatten();
        self.tracker.finish_frame(frame);
        Ok(TrackOutput {
            pose,
            keyframe,
            covariance,
        })
    }

    /// Takes in a map from the mapping half. When it answers the pending request, the
    /// keyframe becomes the reference and its refined pose is returned
    /// (`camera_from_world`); if that keyframe's frame was the last one tracked, the
    /// motion model continues from the refined pose, as ORB-SLAM2 places its last frame
    /// relative to its reference keyframe (`Tracking::UpdateLastFrame`).
    /// A map older than the one held, or newer than the requests made, is ignored (a
    /// restarted tracker receives the last few maps again).
    pub fn apply(&mut self, update: MapUpdate) -> Option<Isometry3<f64>> {
        let answers = self.pending.is_some_and(|(seq, _)| seq == update.seq);
        let stale = update.seq < self.map_seq || (update.seq == self.map_seq && !answers);
        // A map answering a request this tracker has not made (yet): a restarted
        // tracker makes that request again and takes the answer then.
        if stale || update.seq > self.last_request {
            return None;
        }
        self.map_seq = update.seq;
        let (points, lines) = self.sightings.since(&self.map);
        self.map = update.map;
        self.map.canonicalise();
        self.sightings.reset(&self.map);
        apply_sightings(&mut self.map, &points, &lines);
        self.manhattan = update.manhattan;
        let answered = self.pending.filter(|(seq, _)| *seq == update.seq);
        let (_, frame) = answered?;
        self.pending = None;
        let kf = update.keyframe?;
        self.tracker.set_reference(kf);
        self.frames_since_keyframe = 0;
        let refined = self.map.keyframe(kf)?.camera_from_world;
        if self.tracker.last_frame().map(|l| l.features.id) == Some(frame) {
            self.tracker.correct_last_pose(refined);
        }
        Some(refined)
    }

    /// The state a restarted tracker resumes from (with a map from the mapper).
    pub fn checkpoint(&self) -> TrackingCheckpoint {
        let (point_sightings, line_sightings) = self.sightings.since(&self.map);
        TrackingCheckpoint {
            last: self.tracker.last_frame().cloned(),
            motion: self.tracker.motion().clone(),
            point_sightings,
            line_sightings,
            reference: self.tracker.reference(),
            initialised: self.initialised,
            frames_since_keyframe: self.frames_since_keyframe,
            lost_streak: self.lost_streak,
            last_request: self.last_request,
            map_seq: self.map_seq,
            manhattan: self.manhattan.clone(),
        }
    }

    /// Resumes from a checkpoint and the map it tracked against (`checkpoint.map_seq`;
    /// `None`: no map was published, so tracking starts a new map where the checkpoint
    /// left off).
    pub fn restore(&mut self, checkpoint: TrackingCheckpoint, map: Option<MapUpdate>) {
        self.last_request = checkpoint.last_request;
        self.frames_since_keyframe = checkpoint.frames_since_keyframe;
        self.lost_streak = checkpoint.lost_streak;
        self.manhattan = checkpoint.manhattan;
        self.initialised = checkpoint.initialised && map.is_some();
        if let Some(update) = map {
            self.map_seq = update.seq;
            self.map = update.map;
            self.map.canonicalise();
            self.sightings.reset(&self.map);
            apply_sightings(
                &mut self.map,
                &checkpoint.point_sightings,
                &checkpoint.line_sightings,
            );
        }
        if let Some(reference) = checkpoint.reference {
            self.tracker.set_reference(reference);
        }
        if let Some(last) = checkpoint.last {
            self.tracker.restore(checkpoint.motion, last);
        }
    }

    fn request_keyframe(&mut self, frame: &TrackedFrame) -> KeyFrameRequest {
        self.last_request += 1;
        self.pending = Some((self.last_request, frame.features.id));
        let (point_sightings, line_sightings) = self.sightings.since(&self.map);
        self.sightings.reset(&self.map);
        KeyFrameRequest {
            seq: self.last_request,
            frame: frame.clone(),
            manhattan: self.manhattan.clone(),
            reset: std::mem::take(&mut self.reset_owed),
            point_sightings,
            line_sightings,
        }
    }

    /// Starts a map on the first frame with enough keypoints with depth; the world frame
    /// is that camera's (or, after a reset, the predicted pose).
    fn try_initialise(&mut self, features: FrameFeatures) -> TrackedFrame {
        let with_depth = features.keypoints.iter().filter(|k| k.depth > 0.0).count();
        let ready = with_depth >= self.config.tracking.min_initial_points;
        TrackedFrame {
            point_ids: vec![None; features.keypoints.len()],
            line_ids: vec![None; features.lines.len()],
            camera_from_world: self.tracker.predict().unwrap_or_else(Isometry3::identity),
            status: if ready {
                TrackingStatus::Tracked
            } else {
                TrackingStatus::Predicted
            },
            inliers: Default::default(),
            features,
        }
    }

    /// Relocalises a lost frame against the map; after too many lost frames, starts a
    /// new local map at the predicted pose, in the same world frame (the mapping half
    /// drops its keyframes with the next request).
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
        if self.lost_streak < self.config.tracking.frames_before_new_map {
            return;
        }
        tracing::warn!(frame = %frame.features.id, "tracking lost: starting a new local map at the predicted pose");
        for kf in self.map.keyframe_ids() {
            self.map.remove_keyframe(kf);
        }
        self.reset_owed = true;
        self.initialised = false;
        self.lost_streak = 0;
        *frame = self.try_initialise(std::mem::take(&mut frame.features));
    }
}
