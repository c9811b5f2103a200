//! The tracking half of the odometry (the `tracker` service): tracks every frame against
//! its copy of the map, recovers when lost (or asks the mapping half to find the frame
//! in the whole map), decides keyframes and asks the mapping half for them, and takes in
//! the maps the mapping half sends back.

mod checkpoint;
mod frame_pose;
mod reset;
mod saved_map;

pub use checkpoint::TrackingCheckpoint;
pub use frame_pose::FramePose;
pub use reset::ResetError;
pub use saved_map::LoadedMapUse;

use super::messages::{
    KeyFrameRequest, MapUpdate, RelocalisationRequest, Relocalised, TrackedAgainst,
};
use super::state::{MapReceipt, RequestLedger, TrackingState};
use crate::config::OdometryConfig;
use crate::frontend::features::{FeatureError, FrameFeatures};
use crate::map::Map;
use crate::map::manhattan::WorldManhattan;
use crate::mapping::keyframe_policy::{KeyframeContext, needs_keyframe};
use crate::session::final_trajectory::FrameAnchor;
use crate::tracking::inertial::InertialTracker;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::sightings::Sightings;
use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::{TrackedFrame, Tracker};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{FrameId, KeyFrameId};
use gfs_core::stamp::Stamp;
use gfs_inertial::{ImuSample, Pushed};
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Rotation3, UnitQuaternion};

/// A tracked frame's pose, and the keyframe request when it should become one.
#[derive(Debug)]
pub struct TrackOutput {
    /// The pose.
    pub pose: FramePose,
    /// Send this to the mapping half, then hand its answer to
    /// [`TrackingSession::apply`].
    pub keyframe: Option<KeyFrameRequest>,
    /// The frame is lost: send this to the mapping half, then hand its answer to
    /// [`TrackingSession::apply`] (which goes on from the frame's pose when it was found:
    /// [`TrackingSession::take_relocalised`]). Never with `keyframe`.
    pub relocalisation: Option<RelocalisationRequest>,
    /// Covariance of the pose from its optimisation (`gfs_optim::PoseResult::covariance`:
    /// camera-frame translation then rotation); `None` for a predicted pose.
    pub covariance: Option<nalgebra::Matrix6<f64>>,
}

/// A frame starts a map (it becomes its first keyframe); with `reset`, the mapping half
/// must first drop the map that was abandoned.
#[derive(Clone, Copy, Debug)]
struct MapStart {
    reset: bool,
}

/// Tracks frames against a copy of the map that the mapping half keeps up to date.
pub struct TrackingSession {
    config: OdometryConfig,
    tracker: Tracker,
    map: Map,
    manhattan: WorldManhattan,
    sightings: Sightings,
    state: TrackingState,
    requests: RequestLedger,
    frames_since_keyframe: u32,
    map_from_odom: Isometry3<f64>,
    /// `camera_from_world` of the frame of the pending keyframe request, as tracked: the
    /// exact old pose of the keyframe the answer creates (not checkpointed; a restarted
    /// tracker falls back on the keyframes both maps hold).
    requested_pose: Option<Isometry3<f64>>,
    /// The features of the frame of the pending relocalisation request and its
    /// `camera_from_world` as published (the prediction), not checkpointed: a restarted
    /// tracker goes on from the answer's pose alone.
    relocalising: Option<(FrameFeatures, Isometry3<f64>)>,
    /// The pose of the frame the last map taken in relocalised, until taken.
    relocalised: Option<FramePose>,
    /// How a session started on a saved map stands in it.
    saved: saved_map::OnSavedMap,
    /// The IMU's part of tracking (`None` with `[tracking] use_imu` off).
    inertial: Option<InertialTracker>,
    /// The map a reset dropped, until the next frame was tracked against it.
    dropped: Option<Map>,
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
        let scale = ScalePyramid::new(scale_factor, levels);
        Self {
            tracker: Tracker::new(config.tracking.clone(), camera, scale, grid),
            manhattan: WorldManhattan::new(config.tracking.use_manhattan),
            map: Map::default(),
            sightings: Sightings::default(),
            state: TrackingState::default(),
            requests: RequestLedger::default(),
            frames_since_keyframe: 0,
            map_from_odom: Isometry3::identity(),
            requested_pose: None,
            relocalising: None,
            relocalised: None,
            saved: saved_map::OnSavedMap::default(),
            inertial: config
                .tracking
                .use_imu
                .then(|| InertialTracker::new(&config.imu)),
            config,
            dropped: None,
        }
    }

    /// Adds an IMU sample, stamped on the camera's clock, for the frames after it: the
    /// samples up to (and the first one past) a frame's stamp are pushed before the
    /// frame is processed. Says what it did, so the caller can warn naming its source;
    /// with `[tracking] use_imu` off the sample is ignored (and said kept).
    pub fn push_imu(&mut self, sample: ImuSample) -> Pushed {
        self.inertial
            .as_mut()
            .map_or(Pushed::Kept, |inertial| inertial.push(sample))
    }

    /// The IMU's part of tracking (gravity, biases once initialised), when used.
    pub fn inertial(&self) -> Option<&InertialTracker> {
        self.inertial.as_ref()
    }

    /// The loop corrections taken in so far (REP 105 `map -> odom`): the map pose of a
    /// frame is `map_from_odom * FramePose::world_from_camera`.
    pub fn map_from_odom(&self) -> &Isometry3<f64> {
        &self.map_from_odom
    }

    /// The reference keyframe of the last frame.
    pub fn reference(&self) -> Option<KeyFrameId> {
        self.tracker.reference()
    }

    /// The anchor of the frame just processed (whose published pose is `pose`): its
    /// reference keyframe, that keyframe's loop correction and the frame's map pose;
    /// `None` before the first keyframe.
    pub fn anchor(&self, pose: &FramePose) -> Option<FrameAnchor> {
        let keyframe = self.reference()?;
        let correction = self.map.keyframe_correction(keyframe)?;
        Some(FrameAnchor {
            keyframe,
            correction,
            // Composed only once a loop closed: the map pose is then bit for bit the
            // published one.
            world_from_camera: if self.map_from_odom == Isometry3::identity() {
                pose.world_from_camera
            } else {
                self.map_from_odom * pose.world_from_camera
            },
        })
    }

    /// The last frame's matches, inliers and outliers, for a viewer.
    pub fn last_matches(&self) -> Option<crate::tracking::tracker::FrameMatches<'_>> {
        self.tracker.last_matches()
    }

    /// The map the tracker tracks against (the neighbourhood the mapping half sent).
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The keyframes of the last frame's local map.
    pub fn local_keyframes(&self) -> &[KeyFrameId] {
        self.tracker.local_keyframes()
    }

    /// Where tracking stands.
    pub fn state(&self) -> TrackingState {
        self.state
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

    /// The request (keyframe or relocalisation) still waiting for its map (number and
    /// frame), if any.
    pub fn pending_request(&self) -> Option<(u64, FrameId)> {
        self.requests.pending()
    }

    /// True when the next frame cannot be tracked before the pending request's map
    /// arrives: the map is still empty.
    pub fn needs_map(&self) -> bool {
        self.requests.pending().is_some() && self.map.keyframe_count() == 0
    }

    /// The pose of a frame whose features are missing: the motion-model prediction,
    /// flagged [`TrackingStatus::Predicted`], so that the trajectory keeps one line per
    /// input frame.
    pub fn skip(&mut self, id: FrameId, timestamp: Stamp) -> FramePose {
        let camera_from_world = self.tracker.predict().unwrap_or_else(Isometry3::identity);
        let features = FrameFeatures {
            id,
            timestamp,
            ..FrameFeatures::default()
        };
        let frame = TrackedFrame::untracked(features, camera_from_world);
        let mut pose = FramePose::of(&frame);
        if self.map_from_odom != Isometry3::identity() {
            pose.world_from_camera = self.map_from_odom.inverse() * pose.world_from_camera;
        }
        self.tracker.finish_frame(frame);
        pose
    }

    /// Tracks the next frame. Always produces a pose: an untracked frame gets the
    /// motion-model prediction, flagged.
    ///
    /// # Errors
    /// [`FeatureError`] when the feature vectors of the frame do not line up; the frame
    /// is then not used and the caller may go on with the next one.
    pub fn process(&mut self, mut features: FrameFeatures) -> Result<TrackOutput, FeatureError> {
        features.validate()?;
        if !self.config.tracking.use_lines {
            // The ablation switch, honoured here once for tracking and mapping.
            features.lines.clear();
            features.line_descriptors.clear();
            features.lines3d.clear();
        }
        if let Some(inertial) = &mut self.inertial {
            let motion = self.tracker.predict_at(features.timestamp);
            self.tracker
                .set_inertial_prediction(inertial.predict(features.timestamp, motion.as_ref()));
        }
        let (mut frame, start) = self.step(features);
        let inertial = self.inertial.as_mut().map(|inertial| {
            inertial.finish(
                frame.features.timestamp,
                &mut frame.camera_from_world,
                frame.status,
                self.tracker.measured_information(),
            )
        });
        let tracked = frame.status.is_tracked();
        if tracked {
            if let Some(axes) = &frame.features.manhattan {
                self.manhattan
                    .observe(&frame.camera_from_world.inverse(), axes);
            }
            self.frames_since_keyframe += 1;
        }
        // A frame that starts a map is its first keyframe; a fixed map gets none.
        let wants_keyframe = start.is_some()
            || (tracked
                && !self.saved.fixed
                && self.requests.pending().is_none()
                && needs_keyframe(
                    &self.config.keyframes,
                    &KeyframeContext {
                        map: &self.map,
                        reference: self.tracker.reference(),
                        frames_since_keyframe: self.frames_since_keyframe,
                        close_depth_m: self.config.tracking.close_depth_m,
                        min_step_points: self.config.tracking.min_step_inliers(),
                        leaves_depth_reference: self.tracker.leaves_depth_reference(&frame),
                    },
                    &frame,
                ));
        tracing::debug!(
            frame = %frame.features.id,
            status = %frame.status,
            points = frame.inliers.points,
            lines = frame.inliers.lines,
            depth = frame.inliers.depth,
            planes = frame.inliers.planes,
            frame_planes = frame.features.planes.len(),
            keyframe = wants_keyframe,
            keyframes = self.map.keyframe_count(),
            reference = ?self.tracker.reference(),
            "tracked"
        );
        let mut pose = FramePose::of(&frame);
        if self.map_from_odom != Isometry3::identity() {
            pose.world_from_camera = self.map_from_odom.inverse() * pose.world_from_camera;
        }
        if inertial.is_some_and(|i| i.carried) {
            // The images gave nothing, the IMU carried the pose: not a guess yet.
            pose.status = TrackingStatus::Degraded;
        }
        let reset = start.is_some_and(|s| s.reset);
        let keyframe = if wants_keyframe {
            Some(self.request_keyframe(&frame, reset))
        } else {
            self.recentre_request(&frame, tracked)
        };
        let lost = matches!(self.state, TrackingState::Lost { .. });
        let relocalisation = (lost && self.requests.pending().is_none())
            .then(|| self.request_relocalisation(&frame.features, &frame.camera_from_world));
        let covariance = tracked
            .then(|| {
                self.tracker
                    .pose_covariance(&frame, inertial.and_then(|i| i.covariance).as_ref())
            })
            .flatten();
        self.tracker.finish_frame(frame);
        Ok(TrackOutput {
            pose,
            keyframe,
            relocalisation,
            covariance,
        })
    }

    /// Asks the mapping half to find a lost frame (at `camera_from_world`, its
    /// prediction) in the whole map.
    fn request_relocalisation(
        &mut self,
        features: &FrameFeatures,
        camera_from_world: &Isometry3<f64>,
    ) -> RelocalisationRequest {
        self.relocalising = Some((features.clone(), *camera_from_world));
        RelocalisationRequest {
            seq: self.requests.open(features.id),
            features: features.clone(),
        }
    }

    /// The pose of the frame the last map taken in relocalised ([`MapUpdate::
    /// relocalised`]), once: lockstep and inline publish it for the frame that asked;
    /// in realtime that frame's pose went out already, and the frames after it go on
    /// from there.
    pub fn take_relocalised(&mut self) -> Option<FramePose> {
        self.relocalised.take()
    }

    /// Goes on from the frame the mapping half found in the whole map: the frame at its
    /// pose becomes the last one (with its matches when its features are still here),
    /// the motion model restarts there, the keyframe it was found against becomes the
    /// reference. The jump from the frame's prediction to that pose goes into
    /// `map_from_odom` (REP 105: the map pose jumps, the odometry stays continuous).
    fn take_relocalisation(&mut self, found: Relocalised) {
        let asked = self
            .relocalising
            .take()
            .filter(|(f, _)| f.id == found.frame);
        if let Some((_, predicted)) = &asked {
            self.take_in_jump(&found.camera_from_world, predicted);
        }
        let features = asked.map(|(f, _)| f).unwrap_or_else(|| FrameFeatures {
            id: found.frame,
            timestamp: found.timestamp,
            ..FrameFeatures::default()
        });
        let mut frame = TrackedFrame::untracked(features, found.camera_from_world);
        if frame.point_ids.len() == found.point_ids.len() {
            frame.point_ids = found.point_ids;
        }
        frame.inliers.points = found.inliers;
        frame.status = TrackingStatus::Relocalised;
        let mut pose = FramePose::of(&frame);
        if self.map_from_odom != Isometry3::identity() {
            pose.world_from_camera = self.map_from_odom.inverse() * pose.world_from_camera;
        }
        tracing::info!(frame = %found.frame, keyframe = %found.keyframe, inliers = found.inliers, "relocalised against the whole map");
        self.relocalised = Some(pose);
        self.saved.placed(Some(found.keyframe));
        self.tracker.set_reference(found.keyframe);
        if let Some(inertial) = &mut self.inertial {
            inertial.relocalised(found.timestamp, &found.camera_from_world);
        }
        self.tracker.relocalised(frame);
        self.state = TrackingState::Tracking;
        self.frames_since_keyframe = 0;
    }

    /// One transition of the state machine ([`TrackingState`]): the frame as tracked,
    /// and whether it starts a map.
    fn step(&mut self, features: FrameFeatures) -> (TrackedFrame, Option<MapStart>) {
        let lost = match self.state {
            TrackingState::NoMap { reset } => {
                let frame = self.try_initialise(features);
                if !frame.status.is_tracked() {
                    return (frame, None);
                }
                self.state = TrackingState::Tracking;
                return (frame, Some(MapStart { reset }));
            }
            TrackingState::Tracking => 0,
            TrackingState::Lost { frames } => frames,
        };
        let frame = self.tracker.track(&self.map, features, &mut self.sightings);
        if frame.status == TrackingStatus::Relocalised {
            // Found again around the reference keyframe, as a frame found in the whole
            // map is.
            let predicted = self.tracker.prediction();
            self.take_in_jump(&frame.camera_from_world, &predicted);
        }
        if frame.status.is_tracked() {
            self.state = TrackingState::Tracking;
            self.saved.placed(None);
            return (frame, None);
        }
        let frames = lost + 1;
        if frames < self.config.tracking.frames_before_new_map || self.saved.keeps_map() {
            self.state = TrackingState::Lost { frames };
            return (frame, None);
        }
        // A long outage: a new local map at the predicted pose, in the same world
        // frame; the mapping half drops its keyframes with the next request. The
        // prediction is off by the outage's drift, so the new map learns its own
        // Manhattan axes (they travel to the mapper with that request).
        tracing::warn!(frame = %frame.features.id, "tracking lost: starting a new local map at the predicted pose");
        self.map.clear_keyframes();
        self.manhattan = WorldManhattan::new(self.config.tracking.use_manhattan);
        self.state = TrackingState::NoMap { reset: true };
        self.step(frame.features)
    }

    /// Takes in a map from the mapping half; returns true when it answers the pending
    /// request, whose keyframe then becomes the reference. The new keyframe is held
    /// fixed in the local BA, so the frame keeps the pose it was tracked at. Maps that
    /// are older than the one held, or answer a request not made yet, are ignored
    /// ([`RequestLedger::receive`]).
    pub fn apply(&mut self, update: MapUpdate) -> bool {
        let pending = self.requests.pending();
        let receipt = self.requests.receive(update.seq);
        if receipt == MapReceipt::Ignored {
            return false;
        }
        if update.map.corrections() != self.map.corrections() {
            let answered = update
                .keyframe
                .filter(|_| receipt == MapReceipt::Answer)
                .zip(self.requested_pose);
            self.take_correction(&update.map, answered);
        }
        self.map = update.map;
        self.map.canonicalise();
        self.manhattan = update.manhattan;
        if receipt != MapReceipt::Answer {
            return false;
        }
        if let Some(kf) = update.keyframe {
            self.tracker.set_reference(kf);
            self.frames_since_keyframe = 0;
            self.saved.centre = Some(kf);
        }
        let asked = pending.map(|(_, frame)| frame);
        // Only a tracker still lost goes back to the frame (realtime: it may have found
        // its way since).
        let lost = matches!(self.state, TrackingState::Lost { .. });
        match update.relocalised.filter(|r| Some(r.frame) == asked) {
            Some(found) if lost && self.map.keyframe(found.keyframe).is_some() => {
                self.take_relocalisation(found);
            }
            _ => self.relocalising = None,
        }
        true
    }

    /// A relocalised frame was found at `found` where it was predicted at `predicted`
    /// (both `camera_from_world`): the jump goes into `map_from_odom`, so the map pose
    /// jumps and the published odometry stays on the prediction (REP 105).
    fn take_in_jump(&mut self, found: &Isometry3<f64>, predicted: &Isometry3<f64>) {
        if self.saved.unplaced {
            // The first pose on a saved map: nothing was published yet to jump from,
            // so the odometry starts in the map's frame.
            return;
        }
        self.map_from_odom = found.inverse() * predicted * self.map_from_odom;
    }

    /// A map whose loop corrections differ from the held one's moved its keyframes: the
    /// keyframe the map answers (`answered`, with its frame's tracked `camera_from_world`)
    /// or else the newest keyframe both maps hold says how the world moved around the
    /// camera (`new_from_old`); the last frame and the motion model follow it, and so does
    /// `map_from_odom`, so that the published odometry does not jump.
    fn take_correction(&mut self, corrected: &Map, answered: Option<(KeyFrameId, Isometry3<f64>)>) {
        let from_answer = answered.and_then(|(kf, camera_from_world)| {
            Some(corrected.keyframe(kf)?.world_from_camera() * camera_from_world)
        });
        let moved = from_answer.or_else(|| {
            corrected.keyframe_ids().into_iter().rev().find_map(|kf| {
                let old = self.map.keyframe(kf)?;
                let new = corrected.keyframe(kf)?;
                Some(new.world_from_camera() * old.camera_from_world)
            })
        });
        let Some(new_from_old) = moved else {
            return;
        };
        self.tracker.shift_world(&new_from_old);
        if let Some(inertial) = &mut self.inertial {
            inertial.shift_world(&new_from_old);
        }
        self.map_from_odom = new_from_old * self.map_from_odom;
        tracing::info!(
            shift_m = new_from_old.translation.vector.norm(),
            "loop correction taken in"
        );
    }

    fn request_keyframe(&mut self, frame: &TrackedFrame, reset: bool) -> KeyFrameRequest {
        self.requested_pose = Some(frame.camera_from_world);
        self.tracker.keep_requested_keyframe_depth(frame);
        let tracked_against = self
            .tracker
            .reference()
            .filter(|_| !reset)
            .and_then(|reference| {
                Some(TrackedAgainst {
                    corrections: self.map.corrections(),
                    reference,
                    reference_correction: self.map.keyframe_correction(reference)?,
                })
            });
        KeyFrameRequest {
            seq: self.requests.open(frame.features.id),
            frame: frame.clone(),
            manhattan: self.manhattan.clone(),
            reset,
            sightings: self.sightings.take(),
            tracked_against,
        }
    }

    /// Starts a map on the first frame with enough keypoints with depth; the world frame
    /// is that camera's (or, after a reset, its pose tracked on the dropped map or
    /// predicted).
    fn try_initialise(&mut self, features: FrameFeatures) -> TrackedFrame {
        let with_depth = features.keypoints.iter().filter(|k| k.depth > 0.0).count();
        let predicted = match self.pose_on_dropped_map(&features) {
            Some(pose) => pose,
            None => self.tracker.predict().unwrap_or_else(Isometry3::identity),
        };
        let mut frame = TrackedFrame::untracked(features, predicted);
        if with_depth >= self.config.tracking.min_initial_points || self.depth_determines(&frame) {
            frame.status = TrackingStatus::Tracked;
        }
        frame
    }

    /// With the depth alignment or the planes, a frame whose depth or planes alone
    /// determine a pose may start a map whatever its keypoints (a low-texture room).
    fn depth_determines(&self, frame: &TrackedFrame) -> bool {
        let tracking = &self.config.tracking;
        if !tracking.use_depth_alignment && !tracking.use_planes {
            return false;
        }
        let mut information = nalgebra::Matrix6::zeros();
        if tracking.use_depth_alignment && !frame.features.depth.is_empty() {
            information += crate::depth::alignment::self_information(
                &tracking.depth,
                &frame.features.depth,
                0.0,
            );
        }
        if tracking.use_planes {
            information += crate::tracking::plane_association::self_information(
                &tracking.planes,
                &frame.features.planes,
            );
        }
        gfs_optim::analyse_constraint(
            &information,
            tracking.depth.lever_arm_m,
            tracking.depth.max_sigma_m,
        )
        .is_determined()
    }
}
