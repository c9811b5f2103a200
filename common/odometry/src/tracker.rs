//! Frame-to-map tracking (paper section III-C): motion-model prediction, point and
//! grid-based line matching against the last frame, pose optimisation, fallback to the
//! reference keyframe, then local-map tracking and a second optimisation.

use crate::config::TrackingConfig;
use crate::frame::FrameFeatures;
use crate::map::{IdMap, Map};
use crate::matching::{
    LineProjectionMatcher, PointProjectionMatcher, ProjectionCandidate, ScalePyramid,
    match_descriptors,
};
use crate::motion::MotionModel;
use crate::pose_solver::{Inliers, PoseSolver};
use crate::ransac::{Correspondence, RigidRansac};
use crate::rolling_shutter;
use crate::status::TrackingStatus;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{KeyFrameId, MapLineId, MapPointId};
use gfs_lines::grid::{GridConfig, LineGrid};
use gfs_points::KeyPointGrid;
use nalgebra::Isometry3;

/// The result of tracking one frame.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TrackedFrame {
    /// The frame's features.
    pub features: FrameFeatures,
    /// Estimated `camera_from_world`.
    pub camera_from_world: Isometry3<f64>,
    /// How the pose was obtained.
    pub status: TrackingStatus,
    /// Map point matched to each keypoint (inliers only).
    pub point_ids: Vec<Option<MapPointId>>,
    /// Map line matched to each line (inliers only).
    pub line_ids: Vec<Option<MapLineId>>,
    /// Inlier counts of the final optimisation.
    pub inliers: Inliers,
}

/// Keypoint grid cell size in pixels (ORB-SLAM2 uses a 64x48 grid on 640x480: 10 px).
const POINT_GRID_CELL: f32 = 10.0;
/// Fewer matches than this against the last frame: search again with twice the radius.
const RETRY_WIDER_BELOW: usize = 20;
/// Exhaustive matching thresholds against the reference keyframe (ORB-SLAM2 uses
/// `TH_LOW` = 50 with a 0.7 ratio for bag-of-words matching).
const REFERENCE_MAX_DISTANCE: u32 = 64;
const REFERENCE_RATIO: f32 = 0.75;
/// Search radius of the wide fallback, pixels at level 0.
const WIDE_RADIUS_PX: f64 = 50.0;
/// RANSAC hypotheses of the wide fallback.
const WIDE_RANSAC_ITERATIONS: usize = 100;

/// Tracks frames against a [`Map`] it does not own.
pub struct Tracker {
    config: TrackingConfig,
    camera: PinholeCamera,
    scale: ScalePyramid,
    motion: MotionModel,
    last: Option<TrackedFrame>,
    reference: Option<KeyFrameId>,
    point_grid: KeyPointGrid,
    line_grid: LineGrid,
    point_matcher: PointProjectionMatcher,
    line_matcher: LineProjectionMatcher,
    solver: PoseSolver,
    candidates: Vec<ProjectionCandidate>,
    local_lines: Vec<MapLineId>,
    local_keyframes: Vec<KeyFrameId>,
    descriptor_matches: Vec<Option<usize>>,
    ransac: RigidRansac,
    correspondences: Vec<Correspondence>,
    correspondence_keypoints: Vec<(usize, MapPointId)>,
}

impl Tracker {
    /// A tracker for `camera` whose ORB pyramid has `levels` levels `scale_factor` apart.
    pub fn new(
        config: TrackingConfig,
        camera: PinholeCamera,
        scale_factor: f64,
        levels: u8,
        grid: &GridConfig,
    ) -> Self {
        Self {
            point_grid: KeyPointGrid::new(camera.width, camera.height, POINT_GRID_CELL),
            line_grid: LineGrid::new(grid),
            scale: ScalePyramid::new(scale_factor, levels),
            solver: PoseSolver::default(),
            point_matcher: PointProjectionMatcher::default(),
            line_matcher: LineProjectionMatcher::default(),
            motion: MotionModel::default(),
            last: None,
            reference: None,
            candidates: Vec::new(),
            local_lines: Vec::new(),
            local_keyframes: Vec::new(),
            descriptor_matches: Vec::new(),
            ransac: RigidRansac::default(),
            correspondences: Vec::new(),
            correspondence_keypoints: Vec::new(),
            config,
            camera,
        }
    }

    /// The config.
    pub fn config(&self) -> &TrackingConfig {
        &self.config
    }

    /// The scale pyramid of the keypoints.
    pub fn scale(&self) -> &ScalePyramid {
        &self.scale
    }

    /// The keyframe the tracker currently refers to.
    pub fn reference(&self) -> Option<KeyFrameId> {
        self.reference
    }

    /// Sets the reference keyframe (after a keyframe was created).
    pub fn set_reference(&mut self, keyframe: KeyFrameId) {
        self.reference = Some(keyframe);
    }

    /// The covariance of the last pose optimisation (of the frame just tracked).
    pub fn pose_covariance(&self) -> Option<nalgebra::Matrix6<f64>> {
        self.solver.covariance()
    }

    /// The pose predicted for the next frame, if any frame was seen.
    pub fn predict(&self) -> Option<Isometry3<f64>> {
        self.motion.predict()
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
        if frame.status == TrackingStatus::Relocalised {
            self.motion.reset_velocity();
        }
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

    /// Resumes from a checkpoint: the motion model and the last frame as they were.
    pub fn restore(&mut self, motion: MotionModel, last: TrackedFrame) {
        self.motion = motion;
        self.last = Some(last);
    }

    /// Replaces the last frame's pose by a refined one (its keyframe's after the local
    /// BA), keeping the motion model's velocity.
    pub fn correct_last_pose(&mut self, camera_from_world: Isometry3<f64>) {
        self.motion.correct_last(&camera_from_world);
        if let Some(last) = &mut self.last {
            last.camera_from_world = camera_from_world;
        }
    }

    /// Tracks `features` against `map`. Never fails: an untracked frame gets the
    /// predicted pose and [`TrackingStatus::Predicted`].
    pub fn track(&mut self, map: &mut Map, mut features: FrameFeatures) -> TrackedFrame {
        let predicted = self
            .motion
            .predict_at(features.timestamp)
            .unwrap_or_else(Isometry3::identity);
        if self.config.readout_s > 0.0
            && let Some(rate) = self.motion.angular_velocity()
        {
            rolling_shutter::compensate(&mut features, &self.camera, &rate, self.config.readout_s);
        }
        let mut frame = TrackedFrame {
            point_ids: vec![None; features.keypoints.len()],
            line_ids: vec![None; features.lines.len()],
            camera_from_world: predicted,
            status: TrackingStatus::Predicted,
            inliers: Inliers::default(),
            features,
        };
        self.point_grid.build(&frame.features.keypoints);
        if self.config.use_lines {
            self.line_grid.build(
                self.camera.width,
                self.camera.height,
                frame.features.lines.iter().map(|l| &l.segment),
            );
        }
        // Without a velocity the prediction is the last pose: the wide search comes
        // first, and the narrow one only catches a slow start that the wide window's
        // ratio test found too ambiguous.
        let moving = self.motion.velocity().is_some();
        let mut ok = moving && self.track_last_frame(map, &mut frame);
        if !ok {
            restart(&mut frame, &predicted);
            ok = self.track_wide(map, &mut frame);
        }
        if !ok && !moving {
            restart(&mut frame, &predicted);
            ok = self.track_last_frame(map, &mut frame);
        }
        if !ok {
            restart(&mut frame, &predicted);
            ok = self.track_reference_keyframe(map, &mut frame);
        }
        if ok || self.last.is_none() {
            ok = self.track_local_map(map, &mut frame);
        }
        if ok {
            frame.status = if frame.inliers.total() < self.config.degraded_inliers {
                TrackingStatus::Degraded
            } else {
                TrackingStatus::Tracked
            };
        } else {
            frame.camera_from_world = predicted;
            frame.point_ids.iter_mut().for_each(|m| *m = None);
            frame.line_ids.iter_mut().for_each(|m| *m = None);
            frame.inliers = Inliers::default();
        }
        frame
    }

    /// Matches the map landmarks of the last frame by projection from the motion
    /// model's prediction and optimises.
    fn track_last_frame(&mut self, map: &mut Map, frame: &mut TrackedFrame) -> bool {
        if !self.collect_last_frame_landmarks(map) {
            return false;
        }
        let pose = frame.camera_from_world;
        let radius = self.config.points.radius_last_frame;
        let mut matched = self.search_points(map, &pose, frame, radius, false, false);
        if matched < RETRY_WIDER_BELOW {
            frame.point_ids.iter_mut().for_each(|m| *m = None);
            matched = self.search_points(map, &pose, frame, 2.0 * radius, false, false);
        }
        matched += self.search_lines(map, &pose, frame, false);
        if matched < self.config.min_inliers / 2 {
            return false;
        }
        self.optimise(map, frame) >= self.config.min_inliers / 2
    }

    /// The fallback when there is no motion to predict from (second frame, after a
    /// relocalisation) or the prediction failed: the last frame's point landmarks are
    /// searched in a wide window around the predicted pose, RANSAC over the matches
    /// with depth finds the pose and the consistent matches, and the pose is optimised
    /// from there. A window of `WIDE_RADIUS_PX` covers a rotation of about 5 degrees
    /// between two frames; the ratio test and RANSAC sort out the ambiguous matches a
    /// window that wide lets in.
    fn track_wide(&mut self, map: &mut Map, frame: &mut TrackedFrame) -> bool {
        if !self.collect_last_frame_landmarks(map) {
            return false;
        }
        let pose = frame.camera_from_world;
        self.search_points(map, &pose, frame, WIDE_RADIUS_PX, false, false);
        self.correspondences.clear();
        self.correspondence_keypoints.clear();
        for (i, id) in frame.point_ids.iter().enumerate() {
            let (Some(id), Some(kp)) = (id, frame.features.keypoints.get(i)) else {
                continue;
            };
            let pair = map
                .point(*id)
                .and_then(|p| Correspondence::new(&self.camera, kp, p.position));
            if let Some(pair) = pair {
                self.correspondences.push(pair);
                self.correspondence_keypoints.push((i, *id));
            }
        }
        let seed = frame.features.id.0;
        let Some((camera_from_world, inliers)) = self.ransac.solve(
            &self.correspondences,
            &self.camera,
            WIDE_RANSAC_ITERATIONS,
            seed,
        ) else {
            return false;
        };
        if inliers < self.config.min_inliers / 2 {
            return false;
        }
        frame.point_ids.iter_mut().for_each(|m| *m = None);
        for (&(i, id), inlier) in self
            .correspondence_keypoints
            .iter()
            .zip(&self.ransac.inliers)
        {
            if *inlier {
                frame.point_ids[i] = Some(id);
            }
        }
        frame.camera_from_world = camera_from_world;
        self.optimise(map, frame) >= self.config.min_inliers / 2
    }

    /// Fills the point candidates and `local_lines` with the last frame's landmarks;
    /// false without a last frame.
    fn collect_last_frame_landmarks(&mut self, map: &Map) -> bool {
        let Some(last) = &self.last else { return false };
        // When the last frame became the reference keyframe, its landmarks are the
        // keyframe's: the tracked ones (after fusion) and the ones created from its
        // depth, as ORB-SLAM2's RGB-D `CreateNewKeyFrame` links them to the frame.
        let keyframe = self
            .reference
            .and_then(|id| map.keyframe(id))
            .filter(|k| k.features.id == last.features.id);
        let (point_ids, line_ids) = match keyframe {
            Some(k) => (&k.point_ids, &k.line_ids),
            None => (&last.point_ids, &last.line_ids),
        };
        self.candidates.clear();
        for (i, id) in point_ids.iter().enumerate() {
            if let (Some(id), Some(kp)) = (id, last.features.keypoints.get(i)) {
                self.candidates.push(ProjectionCandidate {
                    id: *id,
                    angle: Some(kp.angle),
                });
            }
        }
        self.local_lines.clear();
        self.local_lines.extend(line_ids.iter().flatten());
        true
    }

    /// Matches the reference keyframe's landmarks by descriptor alone and optimises from
    /// the last pose: the fallback when the motion model failed.
    fn track_reference_keyframe(&mut self, map: &mut Map, frame: &mut TrackedFrame) -> bool {
        let Some(reference) = self.reference.and_then(|id| map.keyframe(id)) else {
            return false;
        };
        let train: Vec<_> = reference.point_ids.iter().flatten().copied().collect();
        let train_descriptors: Vec<_> = train
            .iter()
            .filter_map(|id| map.point(*id).map(|p| p.descriptor))
            .collect();
        if train_descriptors.len() != train.len() {
            return false;
        }
        match_descriptors(
            &frame.features.point_descriptors,
            &train_descriptors,
            REFERENCE_MAX_DISTANCE,
            REFERENCE_RATIO,
            &mut self.descriptor_matches,
        );
        frame.point_ids.iter_mut().for_each(|m| *m = None);
        let mut matched = 0;
        for (i, m) in self.descriptor_matches.iter().enumerate() {
            if let Some(t) = m {
                frame.point_ids[i] = Some(train[*t]);
                matched += 1;
            }
        }
        if matched < self.config.min_inliers {
            return false;
        }
        if let Some(last) = &self.last {
            frame.camera_from_world = last.camera_from_world;
        }
        self.optimise(map, frame) >= self.config.min_inliers / 2
    }

    /// Projects the local map (landmarks of the keyframes covisible with the current
    /// matches) into the frame, matches what is not matched yet, and optimises again.
    fn track_local_map(&mut self, map: &mut Map, frame: &mut TrackedFrame) -> bool {
        self.collect_local_keyframes(map, frame);
        let mut seen_points: IdMap<MapPointId, ()> = frame
            .point_ids
            .iter()
            .flatten()
            .map(|id| (*id, ()))
            .collect();
        let mut seen_lines: IdMap<MapLineId, ()> = frame
            .line_ids
            .iter()
            .flatten()
            .map(|id| (*id, ()))
            .collect();
        self.candidates.clear();
        self.local_lines.clear();
        for kf in &self.local_keyframes {
            let Some(keyframe) = map.keyframe(*kf) else {
                continue;
            };
            for id in keyframe.point_ids.iter().flatten() {
                // No angle: rotation consistency is only meaningful for matches against
                // one other view, so the local map skips the orientation check.
                if seen_points.insert(*id, ()).is_none() {
                    self.candidates.push(ProjectionCandidate {
                        id: *id,
                        angle: None,
                    });
                }
            }
            for id in keyframe.line_ids.iter().flatten() {
                if seen_lines.insert(*id, ()).is_none() {
                    self.local_lines.push(*id);
                }
            }
        }
        let pose = frame.camera_from_world;
        let radius = self.config.points.radius_local_map;
        self.search_points(map, &pose, frame, radius, true, true);
        self.search_lines(map, &pose, frame, true);
        let inliers = self.optimise(map, frame);
        for id in frame.point_ids.iter().flatten() {
            if let Some(p) = map.point_mut(*id) {
                p.found += 1;
            }
        }
        for id in frame.line_ids.iter().flatten() {
            if let Some(l) = map.line_mut(*id) {
                l.found += 1;
            }
        }
        inliers >= self.config.min_inliers
    }

    /// The keyframes that share the most landmarks with the current matches, plus the
    /// best covisible neighbours of those, up to `local_keyframes`.
    fn collect_local_keyframes(&mut self, map: &Map, frame: &TrackedFrame) {
        let mut votes: IdMap<KeyFrameId, u32> = IdMap::default();
        let point_obs = frame
            .point_ids
            .iter()
            .flatten()
            .filter_map(|id| map.point(*id))
            .map(|p| &p.observations);
        let line_obs = frame
            .line_ids
            .iter()
            .flatten()
            .filter_map(|id| map.line(*id))
            .map(|l| &l.observations);
        for observations in point_obs.chain(line_obs) {
            for (kf, _) in observations {
                *votes.entry(*kf).or_insert(0) += 1;
            }
        }
        let mut ranked: Vec<_> = votes.into_iter().collect();
        ranked.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(b.0.cmp(&a.0)));
        self.local_keyframes.clear();
        self.local_keyframes.extend(
            ranked
                .iter()
                .map(|(kf, _)| *kf)
                .take(self.config.local_keyframes),
        );
        if let Some((best, _)) = ranked.first() {
            self.reference = Some(*best);
        }
        let mut i = 0;
        while i < self.local_keyframes.len()
            && self.local_keyframes.len() < self.config.local_keyframes
        {
            for (neighbour, _) in map
                .covisible(self.local_keyframes[i], 15)
                .into_iter()
                .take(5)
            {
                if !self.local_keyframes.contains(&neighbour)
                    && self.local_keyframes.len() < self.config.local_keyframes
                {
                    self.local_keyframes.push(neighbour);
                }
            }
            i += 1;
        }
        if self.local_keyframes.is_empty()
            && let Some(reference) = self.reference
        {
            self.local_keyframes.push(reference);
        }
    }

    fn search_points(
        &mut self,
        map: &mut Map,
        pose: &Isometry3<f64>,
        frame: &mut TrackedFrame,
        radius: f64,
        by_viewing_angle: bool,
        count_visible: bool,
    ) -> usize {
        self.point_matcher.search(
            map,
            &self.candidates,
            pose,
            &self.camera,
            &frame.features,
            &self.point_grid,
            &self.scale,
            radius,
            by_viewing_angle,
            &self.config.points,
            count_visible,
            &mut frame.point_ids,
        )
    }

    fn search_lines(
        &mut self,
        map: &mut Map,
        pose: &Isometry3<f64>,
        frame: &mut TrackedFrame,
        count_visible: bool,
    ) -> usize {
        if !self.config.use_lines {
            return 0;
        }
        let mut matched = self.line_matcher.search(
            map,
            &self.local_lines,
            pose,
            &self.camera,
            &frame.features,
            &self.line_grid,
            &self.config.lines,
            false,
            count_visible,
            &mut frame.line_ids,
        );
        let total = frame.line_ids.iter().flatten().count();
        if total < self.config.extension_search_below {
            matched += self.line_matcher.search(
                map,
                &self.local_lines,
                pose,
                &self.camera,
                &frame.features,
                &self.line_grid,
                &self.config.lines,
                true,
                false,
                &mut frame.line_ids,
            );
        }
        matched
    }

    /// Optimises the frame pose from its matches; outliers are unlinked. Returns the
    /// number of inliers (points + lines).
    fn optimise(&mut self, map: &Map, frame: &mut TrackedFrame) -> usize {
        frame.inliers = self.solver.solve(
            map,
            &frame.features,
            &self.camera,
            &self.scale,
            &mut frame.camera_from_world,
            &mut frame.point_ids,
            if self.config.use_lines {
                &mut frame.line_ids
            } else {
                &mut []
            },
        );
        frame.inliers.total()
    }
}

/// Puts `frame` back to its predicted pose with no matches, for the next tracking try.
fn restart(frame: &mut TrackedFrame, predicted: &Isometry3<f64>) {
    frame.camera_from_world = *predicted;
    frame.point_ids.iter_mut().for_each(|m| *m = None);
    frame.line_ids.iter_mut().for_each(|m| *m = None);
}
