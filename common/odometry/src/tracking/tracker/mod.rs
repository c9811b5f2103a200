//! Frame-to-map tracking (paper section III-C). A frame is predicted with the motion
//! model, re-timed for the rolling shutter, then tracked by the first [`Strategy`] of
//! [`Strategy::order`] that finds enough inliers; the local map then adds its matches
//! and the pose is optimised again. A frame no strategy tracks is relocalised against
//! the place of the reference keyframe, or keeps the predicted pose (and the tracking
//! half asks the mapping half to relocalise it against the whole map).
//!
//! The tracker reads the map and never changes it: what it saw of each landmark goes
//! into [`Sightings`], which travel to the map's owner with the next keyframe request.

mod depth;
mod local_map;
mod planes;
mod strategies;
mod tracked_frame;

pub use tracked_frame::{FrameMatches, TrackedFrame};

use crate::config::TrackingConfig;
use crate::depth::alignment::DepthAssociator;
use crate::depth::reference_intensity::ReferenceIntensity;
use crate::depth::vignetting::Vignetting;
use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::tracking::matching::{
    LineProjectionMatcher, PointProjectionMatcher, ProjectionCandidate, ScalePyramid,
};
use crate::tracking::motion::MotionModel;
use crate::tracking::motion_prior::{FilteredVelocity, VelocityChange};
use crate::tracking::plane_association::PlaneAssociator;
use crate::tracking::pose_solver::{Inliers, PoseSolver};
use crate::tracking::pose_uncertainty::{PoseJitter, larger_of, measurement_covariance};
use crate::tracking::ransac::{Correspondence, RigidRansac};
use crate::tracking::relocalisation::around_reference::relocalise;
use crate::tracking::rolling_shutter;
use crate::tracking::sightings::Sightings;
use crate::tracking::status::TrackingStatus;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{FrameId, KeyFrameId, MapLineId, MapPlaneId, MapPointId};
use gfs_lines::grid::GridConfig;
use nalgebra::Isometry3;

/// One way of finding a frame's pose from a prediction; [`Strategy::order`] says which
/// are tried, in which order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// The last frame's landmarks projected with the motion model's prediction and
    /// matched in a narrow window (ORB-SLAM2 `TrackWithMotionModel`).
    MotionModel,
    /// The last frame's point landmarks searched in a wide window, RANSAC over the
    /// matches with depth (catches motion the prediction missed).
    WideRansac,
    /// The reference keyframe's points matched by descriptor alone, optimised from the
    /// last pose (ORB-SLAM2 `TrackReferenceKeyFrame`).
    ReferenceKeyFrame,
}

impl Strategy {
    /// The strategies to try, first to last. Without a velocity the prediction is only
    /// the last pose, so the wide search comes first, and the narrow one only catches a
    /// slow start that the wide window's ratio test found too ambiguous.
    pub fn order(moving: bool) -> &'static [Strategy] {
        if moving {
            &[Self::MotionModel, Self::WideRansac, Self::ReferenceKeyFrame]
        } else {
            &[Self::WideRansac, Self::MotionModel, Self::ReferenceKeyFrame]
        }
    }
}

/// Tracks frames against a [`Map`] it reads.
pub struct Tracker {
    config: TrackingConfig,
    camera: PinholeCamera,
    motion: MotionModel,
    last: Option<TrackedFrame>,
    reference: Option<KeyFrameId>,
    points: PointProjectionMatcher,
    lines: LineProjectionMatcher,
    solver: PoseSolver,
    candidates: Vec<ProjectionCandidate>,
    local_lines: Vec<MapLineId>,
    local_keyframes: Vec<KeyFrameId>,
    /// Keyframes sharing the frame's view, `(distance, id)` (reused).
    view_keyframes: Vec<(f64, KeyFrameId)>,
    descriptor_matches: Vec<Option<usize>>,
    ransac: RigidRansac,
    correspondences: Vec<Correspondence>,
    correspondence_keypoints: Vec<(usize, MapPointId)>,
    depth_associator: DepthAssociator,
    photometric_associator: crate::depth::photometric::PhotometricAssociator,
    /// Depth pairs of the last association pass.
    depth_pairs: usize,
    plane_associator: PlaneAssociator,
    /// `(frame plane, map plane)` pairs set on the solver.
    plane_pairs: Vec<(usize, MapPlaneId)>,
    /// The newest keyframe's depth (`[tracking.depth] keyframe_reference`).
    keyframe_depth: Option<(KeyFrameId, crate::depth::grid::DepthGrid)>,
    /// The frame the last keyframe request was made of, until the map holds that
    /// keyframe, and its depth (the buffer stays for the next request).
    requested_keyframe_depth: (Option<FrameId>, crate::depth::grid::DepthGrid),
    /// The newest keyframe's intensities averaged with the frames tracked against it.
    reference_intensity: ReferenceIntensity,
    /// The prediction the last frame started from.
    predicted: Isometry3<f64>,
    /// Seconds from the frame before to the last frame, when the motion model had a
    /// velocity to predict over: the prior of the depth and geometry passes
    /// (`motion_prior.rs`) needs both.
    predicted_over_s: Option<f64>,
    /// What the data of the frame being tracked determined of its pose (the normals'
    /// noise discounted), for the filtered velocity.
    tracked_information: Option<nalgebra::Matrix6<f64>>,
    /// The camera's velocity as the frames' data placed them: the prior's centre.
    velocity_filter: FilteredVelocity,
    /// The colour camera's falloff, estimated from the tracked frames.
    vignetting: Vignetting,
    /// The jitter of the tracked poses the measurements do not explain.
    jitter: PoseJitter,
    /// The next frame's prediction from the IMU, when its samples cover the interval:
    /// taken instead of the motion model's.
    inertial_prediction: Option<Isometry3<f64>>,
}

impl Tracker {
    /// A tracker for `camera` whose keypoints come from the pyramid `scale`; `grid` is
    /// the line grid of the line front end.
    pub fn new(
        config: TrackingConfig,
        camera: PinholeCamera,
        scale: ScalePyramid,
        grid: &GridConfig,
    ) -> Self {
        Self {
            points: PointProjectionMatcher::new(config.points.clone(), camera, scale),
            lines: LineProjectionMatcher::new(config.lines.clone(), camera, grid),
            solver: PoseSolver::new(config.pose.clone(), camera, scale),
            motion: MotionModel::default(),
            last: None,
            reference: None,
            candidates: Vec::new(),
            local_lines: Vec::new(),
            local_keyframes: Vec::new(),
            view_keyframes: Vec::new(),
            descriptor_matches: Vec::new(),
            ransac: RigidRansac::default(),
            correspondences: Vec::new(),
            correspondence_keypoints: Vec::new(),
            depth_associator: DepthAssociator::default(),
            photometric_associator: Default::default(),
            depth_pairs: 0,
            plane_associator: PlaneAssociator::default(),
            plane_pairs: Vec::new(),
            keyframe_depth: None,
            requested_keyframe_depth: Default::default(),
            reference_intensity: Default::default(),
            predicted: Isometry3::identity(),
            predicted_over_s: None,
            tracked_information: None,
            velocity_filter: FilteredVelocity::default(),
            vignetting: Vignetting::default(),
            jitter: PoseJitter::default(),
            inertial_prediction: None,
            config,
            camera,
        }
    }

    /// The keyframes of the last local map (covisible with the matches, and sharing the
    /// frame's view).
    pub fn local_keyframes(&self) -> &[KeyFrameId] {
        &self.local_keyframes
    }

    /// The keyframe the tracker currently refers to.
    pub fn reference(&self) -> Option<KeyFrameId> {
        self.reference
    }

    /// Sets the reference keyframe (after a keyframe was created).
    pub fn set_reference(&mut self, keyframe: KeyFrameId) {
        self.reference = Some(keyframe);
    }

    /// The covariance of `frame`, just tracked (before [`Self::finish_frame`]): the
    /// larger along every direction of what its measurements determine (the motion
    /// prior left out; with the IMU, `inertial`: its joint estimate with the inertial
    /// term) and of the jitter of the poses up to it
    /// ([`crate::tracking::pose_uncertainty`]). `None` for a frame not posed by the
    /// optimisation (predicted, relocalised) or whose last solve did not converge.
    pub fn pose_covariance(
        &self,
        frame: &TrackedFrame,
        inertial: Option<&nalgebra::Matrix6<f64>>,
    ) -> Option<nalgebra::Matrix6<f64>> {
        let information = self.tracked_information.as_ref()?;
        self.solver.converged().then(|| {
            larger_of(
                &inertial.copied().unwrap_or_else(|| {
                    measurement_covariance(information, self.config.depth.lever_arm_m)
                }),
                &self
                    .jitter
                    .covariance_with(&frame.camera_from_world, frame.features.timestamp.secs()),
            )
        })
    }

    /// The last frame's matches, inliers and outliers (`None` before the first frame).
    pub fn last_matches(&self) -> Option<FrameMatches<'_>> {
        self.last.as_ref().map(|frame| FrameMatches {
            frame,
            solver: &self.solver,
        })
    }

    /// The pose predicted for the next frame, if any frame was seen.
    pub fn predict(&self) -> Option<Isometry3<f64>> {
        self.motion.predict()
    }

    /// The motion model's prediction of a frame at `timestamp`.
    pub fn predict_at(&self, timestamp: gfs_core::stamp::Stamp) -> Option<Isometry3<f64>> {
        self.motion.predict_at(timestamp)
    }

    /// The IMU's prediction of the next frame to track (`camera_from_world`), or `None`
    /// for the motion model's.
    pub fn set_inertial_prediction(&mut self, predicted: Option<Isometry3<f64>>) {
        self.inertial_prediction = predicted;
    }

    /// What the measurements of the frame just tracked determine of its pose (`None`
    /// when the images did not pose it).
    pub fn measured_information(&self) -> Option<&nalgebra::Matrix6<f64>> {
        self.tracked_information.as_ref()
    }

    /// The prediction the last [`Self::track`] started from (`camera_from_world`).
    pub fn prediction(&self) -> Isometry3<f64> {
        self.predicted
    }

    /// The motion model's velocity (`current_from_previous`), if known.
    pub fn velocity(&self) -> Option<&Isometry3<f64>> {
        self.motion.velocity()
    }

    /// Records the final state of a frame (after keyframe decisions) as the last frame.
    pub fn finish_frame(&mut self, frame: TrackedFrame) {
        self.motion.update(
            &frame.camera_from_world,
            frame.features.timestamp,
            frame.status.is_tracked(),
        );
        self.observe_vignetting(&frame);
        let information = self.tracked_information.take();
        self.jitter.observe(
            &frame.camera_from_world,
            frame.features.timestamp.secs(),
            matches!(
                frame.status,
                TrackingStatus::Tracked | TrackingStatus::Degraded
            ),
        );
        if frame.status == TrackingStatus::Relocalised {
            self.motion.reset_velocity();
            self.restart_velocity_filter(&frame);
        } else {
            self.velocity_filter.update(
                &frame.camera_from_world,
                frame.features.timestamp,
                information.as_ref(),
                VelocityChange::from_config(&self.config.depth),
            );
        }
        self.last = Some(frame);
    }

    /// Goes on from a frame the mapping half relocalised (`frame`, at its pose, as the
    /// last frame): the motion model restarts there, without a velocity.
    pub fn relocalised(&mut self, frame: TrackedFrame) {
        self.vignetting.next_frame();
        self.motion = MotionModel::default();
        self.motion
            .update(&frame.camera_from_world, frame.features.timestamp, true);
        self.restart_velocity_filter(&frame);
        self.jitter.restart();
        self.last = Some(frame);
    }

    /// The last frame finished, with its features and matches.
    pub fn last_frame(&self) -> Option<&TrackedFrame> {
        self.last.as_ref()
    }

    /// The motion model (for checkpoints).
    pub fn motion(&self) -> &MotionModel {
        &self.motion
    }

    /// Re-expresses the last frame and the motion model in a corrected world
    /// (`new_from_old`, a loop correction), so that tracking goes on in the corrected map.
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        self.motion.shift_world(new_from_old);
        self.velocity_filter.shift_world(new_from_old);
        self.jitter.shift_world(new_from_old);
        if let Some(last) = &mut self.last {
            last.camera_from_world *= new_from_old.inverse();
        }
    }

    /// Starts the centre's velocity afresh at `frame` (no velocity: the motion model's
    /// step centres the prior until two frames have been tracked).
    fn restart_velocity_filter(&mut self, frame: &TrackedFrame) {
        self.velocity_filter = FilteredVelocity::default();
        self.velocity_filter.update(
            &frame.camera_from_world,
            frame.features.timestamp,
            None,
            VelocityChange::from_config(&self.config.depth),
        );
    }

    /// Resumes from a checkpoint: the motion model and the last frame as they were.
    pub fn restore(&mut self, motion: MotionModel, last: TrackedFrame) {
        self.motion = motion;
        self.restart_velocity_filter(&last);
        self.jitter.restart();
        self.last = Some(last);
    }

    /// Tracks `features` against `map`, counting what it sees in `sightings`. Never
    /// fails: an untracked frame gets the predicted pose and
    /// [`TrackingStatus::Predicted`].
    pub fn track(
        &mut self,
        map: &Map,
        mut features: FrameFeatures,
        sightings: &mut Sightings,
    ) -> TrackedFrame {
        self.hold_keyframe_depth(map);
        if self.config.use_depth_alignment && self.config.depth.estimate_vignetting {
            self.vignetting.correct(&self.camera, &mut features.depth);
        }
        let predicted = self
            .inertial_prediction
            .take()
            .or_else(|| self.motion.predict_at(features.timestamp))
            .unwrap_or_else(Isometry3::identity);
        if self.config.readout_s > 0.0
            && let Some(rate) = self.motion.angular_velocity()
        {
            rolling_shutter::compensate(&mut features, &self.camera, &rate, self.config.readout_s);
        }
        self.predicted = predicted;
        self.predicted_over_s = self.motion.interval_to(features.timestamp);
        let mut frame = TrackedFrame::untracked(features, predicted);
        self.tracked_information = None;
        self.points.index(&frame.features);
        self.lines.index(&frame.features);
        let moving = self.motion.velocity().is_some();
        let mut ok = false;
        for strategy in Strategy::order(moving) {
            frame.restart(&predicted);
            ok = match strategy {
                Strategy::MotionModel => self.track_last_frame(map, &mut frame),
                Strategy::WideRansac => self.track_wide(map, &mut frame),
                Strategy::ReferenceKeyFrame => self.track_reference_keyframe(map, &mut frame),
            };
            if ok {
                break;
            }
        }
        // Without a last frame (a restarted tracker whose checkpoint had none) the
        // local map around the reference keyframe is all there is to track against.
        if ok || self.last.is_none() {
            ok = self.track_local_map(map, &mut frame, sightings);
        }
        let use_depth = self.config.use_depth_alignment;
        let use_planes = self.config.use_planes;
        if ok {
            if use_planes {
                self.refine_with_planes(map, &mut frame);
            }
            if use_depth {
                self.refine_with_depth(map, &mut frame);
            }
            if use_planes || use_depth {
                self.keep_plane_inliers(&mut frame);
                self.clear_planes();
                frame.status = self.status_from_information();
                self.add_view_to_reference(map, &frame);
            } else {
                frame.status = if frame.inliers.total() < self.config.degraded_inliers {
                    TrackingStatus::Degraded
                } else {
                    self.status_from_information()
                };
            }
            self.tracked_information = Some(self.determined_information(&frame));
            return frame;
        }
        frame.restart(&predicted);
        frame.inliers = Inliers::default();
        if use_depth || use_planes {
            self.keep_few_matches(map, &mut frame, &predicted);
        }
        let on_geometry =
            if (use_depth || use_planes) && self.last_frame_is_recent(frame.features.timestamp) {
                self.track_on_geometry_or_register(map, &mut frame, &predicted)
            } else {
                None
            };
        if let Some(status) = on_geometry {
            frame.status = status;
            self.tracked_information = Some(self.determined_information(&frame));
            self.add_view_to_reference(map, &frame);
            return frame;
        }
        frame.restart(&predicted);
        frame.inliers = Inliers::default();
        self.relocalise(map, &mut frame);
        frame
    }

    /// Relocalises a lost frame against the place of the reference keyframe (it and its
    /// connected keyframes, where the camera was lost); the frame keeps its predicted
    /// pose when that fails, and the tracking half asks the mapping half to search the
    /// whole map ([`crate::MapRelocaliser`]).
    fn relocalise(&self, map: &Map, frame: &mut TrackedFrame) {
        let Some(reference) = self.reference else {
            return;
        };
        let seed = frame.features.id.0;
        let min_inliers = self.config.relocalisation_min_inliers;
        let points = map.place_points(reference);
        if let Some(found) = relocalise(
            map,
            &points,
            &frame.features,
            &self.camera,
            min_inliers,
            seed,
        ) {
            frame.camera_from_world = found.camera_from_world;
            frame.point_ids = found.point_ids;
            frame.inliers.points = found.inliers;
            frame.status = TrackingStatus::Relocalised;
        }
    }

    /// Optimises the frame pose from its matches; outliers are unlinked. Returns the
    /// number of inliers (points + lines).
    fn optimise(&mut self, map: &Map, frame: &mut TrackedFrame) -> usize {
        frame.inliers = self.solver.solve(
            map,
            &frame.features,
            &mut frame.camera_from_world,
            &mut frame.point_ids,
            &mut frame.line_ids,
        );
        frame.inliers.total()
    }
}

#[cfg(test)]
mod covariance_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, camera, first_keyframe, pose, relinked, scale};

    fn tracker() -> Tracker {
        Tracker::new(
            TrackingConfig::default(),
            camera(),
            scale(),
            &GridConfig::default(),
        )
    }

    #[test]
    fn the_motion_model_goes_first_once_there_is_motion() {
        assert_eq!(Strategy::order(true)[0], Strategy::MotionModel);
        assert_eq!(Strategy::order(false)[0], Strategy::WideRansac);
        for moving in [true, false] {
            assert_eq!(Strategy::order(moving).len(), 3);
            assert_eq!(Strategy::order(moving)[2], Strategy::ReferenceKeyFrame);
        }
    }

    #[test]
    fn without_a_velocity_a_turn_is_tracked_and_the_sightings_counted() {
        let scene = Scene::new(200, 20);
        let (map, _, kf) = first_keyframe(&scene, &OdometryConfig::default());
        let mut tracker = tracker();
        tracker.set_reference(kf);
        tracker.finish_frame(relinked(map.keyframe(kf).expect("kf")));
        // 3 degrees and 3 cm from the last frame, which the prediction (the last pose)
        // does not know.
        let truth = pose(0.03, 3f64.to_radians());
        let mut sightings = Sightings::default();
        let frame = tracker.track(&map, scene.features(1, &truth), &mut sightings);
        assert_eq!(frame.status, TrackingStatus::Tracked);
        let error = frame.camera_from_world * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-6, "{error}");
        assert!(frame.inliers.points > 150 && frame.inliers.lines > 10);
        let some = frame.point_ids.iter().flatten().next().expect("a match");
        assert_eq!(sightings.point(*some).found, 1);
        assert_eq!(tracker.reference(), Some(kf));
    }

    #[test]
    fn a_frame_that_matches_nothing_keeps_the_prediction() {
        let scene = Scene::new(200, 0);
        let (map, _, kf) = first_keyframe(&scene, &OdometryConfig::default());
        let mut tracker = tracker();
        tracker.set_reference(kf);
        tracker.finish_frame(relinked(map.keyframe(kf).expect("kf")));
        // The same geometry with other descriptors: nothing matches, relocalisation
        // included.
        let mut features = scene.features(1, &pose(0.01, 0.0));
        for d in &mut features.point_descriptors {
            d[0] = !d[0];
            d[2] = !d[2];
        }
        let mut sightings = Sightings::default();
        let frame = tracker.track(&map, features, &mut sightings);
        assert_eq!(frame.status, TrackingStatus::Predicted);
        assert_eq!(frame.camera_from_world, Isometry3::identity());
        assert!(frame.point_ids.iter().all(Option::is_none));
    }
}
