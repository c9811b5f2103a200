//! The tracking strategies of [`super::Strategy`]: each matches the frame against part
//! of the map from a prediction and optimises the pose; true when enough inliers
//! remain.

use super::{TrackedFrame, Tracker};
use crate::map::Map;
use crate::tracking::matching::{LineWindow, PointWindow, ProjectionCandidate, match_descriptors};
use crate::tracking::ransac::Correspondence;
use nalgebra::Isometry3;

/// Fewer point matches than this against the last frame: search again with twice the
/// radius (ORB-SLAM2 `TrackWithMotionModel`: 20).
const RETRY_WIDER_BELOW: usize = 20;
/// Exhaustive matching thresholds against the reference keyframe (ORB-SLAM2 uses
/// `TH_LOW` = 50 with a 0.7 ratio for bag-of-words matching).
const REFERENCE_MAX_DISTANCE: u32 = 64;
const REFERENCE_RATIO: f32 = 0.75;
/// Fewest inlier matches kept for a frame tracked on its geometry: along the direction
/// the geometry leaves free, one wrong match pulls the pose as far as it likes (low-
/// texture rotation seed 1, frame 6: one line moved it 26 cm).
const MIN_KEPT_MATCHES: usize = 6;
/// Search radius of the wide strategy, pixels at level 0: about 5 degrees of rotation
/// between two frames.
const WIDE_RADIUS_PX: f64 = 50.0;
/// RANSAC hypotheses of the wide strategy.
const WIDE_RANSAC_ITERATIONS: usize = 100;

impl Tracker {
    /// [`super::Strategy::MotionModel`]: the last frame's landmarks projected from the
    /// prediction, matched in a narrow window, then optimised.
    pub(super) fn track_last_frame(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        if !self.collect_last_frame_landmarks(map) {
            return false;
        }
        let pose = frame.camera_from_world;
        let radius = self.config.points.radius_last_frame;
        let mut matched = self.points.search(
            map,
            &self.candidates,
            &pose,
            &frame.features,
            PointWindow::Radius(radius),
            &mut frame.point_ids,
        );
        if matched < RETRY_WIDER_BELOW {
            frame.point_ids.iter_mut().for_each(|m| *m = None);
            matched = self.points.search(
                map,
                &self.candidates,
                &pose,
                &frame.features,
                PointWindow::Radius(2.0 * radius),
                &mut frame.point_ids,
            );
        }
        matched += self.search_lines(map, &pose, frame);
        let min_inliers = self.config.min_step_inliers();
        matched >= min_inliers && self.optimise(map, frame) >= min_inliers
    }

    /// [`super::Strategy::WideRansac`]: the last frame's point landmarks searched in a
    /// wide window around the prediction; RANSAC over the matches with depth finds the
    /// pose and the consistent matches, and the pose is optimised from there. The ratio
    /// test and RANSAC sort out the ambiguous matches a window that wide lets in.
    pub(super) fn track_wide(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        if !self.collect_last_frame_landmarks(map) {
            return false;
        }
        let pose = frame.camera_from_world;
        self.points.search(
            map,
            &self.candidates,
            &pose,
            &frame.features,
            PointWindow::Radius(WIDE_RADIUS_PX),
            &mut frame.point_ids,
        );
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
        let min_inliers = self.config.min_step_inliers();
        if inliers < min_inliers {
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
        self.optimise(map, frame) >= min_inliers
    }

    /// [`super::Strategy::ReferenceKeyFrame`]: the reference keyframe's landmarks
    /// matched by descriptor alone, optimised from the last pose.
    pub(super) fn track_reference_keyframe(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
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
        self.optimise(map, frame) >= self.config.min_step_inliers()
    }

    /// The last frame's landmarks matched from `predicted` as
    /// [`super::Strategy::MotionModel`] does, kept even when too few to track on: with
    /// the depth and planes they constrain the directions the geometry leaves free (a
    /// wall and the floor leave the translation along their edge). The frame keeps the
    /// predicted pose: a few matches alone may pull it anywhere.
    pub(super) fn keep_few_matches(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        predicted: &Isometry3<f64>,
    ) {
        self.track_last_frame(map, frame);
        frame.camera_from_world = *predicted;
        if frame.inliers.total() < MIN_KEPT_MATCHES {
            frame.restart(predicted);
            frame.inliers = Default::default();
        }
    }

    /// Matches `local_lines` into the frame from `pose`; when too few of the frame's
    /// lines are matched, the extension search looks again along the projected lines.
    /// Returns the number of new matches.
    pub(super) fn search_lines(
        &mut self,
        map: &Map,
        pose: &Isometry3<f64>,
        frame: &mut TrackedFrame,
    ) -> usize {
        let matched = self.lines.search(
            map,
            &self.local_lines,
            pose,
            &frame.features,
            LineWindow::Segment,
            &mut frame.line_ids,
        );
        matched + self.extension_search(map, pose, frame)
    }

    /// The extension search (paper Fig. 6), when fewer than `extension_search_below`
    /// of the frame's lines are matched: `local_lines` looked for again along the
    /// projected lines' extensions. Returns the number of new matches.
    pub(super) fn extension_search(
        &mut self,
        map: &Map,
        pose: &Isometry3<f64>,
        frame: &mut TrackedFrame,
    ) -> usize {
        let total = frame.line_ids.iter().flatten().count();
        if total >= self.config.extension_search_below {
            return 0;
        }
        self.lines.search(
            map,
            &self.local_lines,
            pose,
            &frame.features,
            LineWindow::Extension,
            &mut frame.line_ids,
        )
    }

    /// Fills the point candidates and `local_lines` with the last frame's landmarks;
    /// false without a last frame.
    pub(super) fn collect_last_frame_landmarks(&mut self, map: &Map) -> bool {
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
}
