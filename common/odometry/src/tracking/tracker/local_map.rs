//! Local-map tracking (ORB-SLAM2 `TrackLocalMap`): once a strategy found the pose, the
//! landmarks of the keyframes around the current matches, and of the keyframes that
//! share the frame's view, are projected into the frame, matched where not matched yet,
//! and the pose is optimised again.

use super::{TrackedFrame, Tracker};
use crate::map::{COVISIBILITY_MIN_SHARED, IdMap, Map};
use crate::tracking::matching::{LineWindow, PointWindow, ProjectionCandidate};
use crate::tracking::sightings::Sightings;
use gfs_core::ids::{KeyFrameId, MapLineId, MapPointId};

/// Covisible neighbours of each local keyframe added to the local map (ORB-SLAM2
/// `UpdateLocalKeyFrames`: 10; fewer suffice with this map's fewer keyframes).
const NEIGHBOURS_PER_KEYFRAME: usize = 5;

impl Tracker {
    /// Matches the local map into the frame and optimises; counts what was predicted in
    /// view and what was matched in `sightings`. True with at least `min_inliers`.
    pub(super) fn track_local_map(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        sightings: &mut Sightings,
    ) -> bool {
        self.collect_local_keyframes(map, frame);
        self.collect_local_landmarks(map, frame);
        let pose = frame.camera_from_world;
        let window = PointWindow::ByViewingAngle(self.config.points.radius_local_map);
        self.points.search(
            map,
            &self.candidates,
            &pose,
            &frame.features,
            window,
            &mut frame.point_ids,
        );
        sightings.points_visible(self.points.in_view());
        self.lines.search(
            map,
            &self.local_lines,
            &pose,
            &frame.features,
            LineWindow::Segment,
            &mut frame.line_ids,
        );
        sightings.lines_visible(self.lines.in_view());
        self.extension_search(map, &pose, frame);
        let inliers = self.optimise(map, frame);
        sightings.points_found(frame.point_ids.iter().flatten());
        sightings.lines_found(frame.line_ids.iter().flatten());
        inliers >= self.config.min_inliers
    }

    /// Fills the point candidates and `local_lines` with the landmarks of the local
    /// keyframes that the frame has not matched yet.
    fn collect_local_landmarks(&mut self, map: &Map, frame: &TrackedFrame) {
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
    }

    /// The keyframes that share the most landmarks with the current matches (the best
    /// becomes the reference), plus the strongest covisible neighbours of those, up to
    /// `local_keyframes`.
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
        // A neighbourhood's landmarks also name keyframes it does not hold.
        for observations in point_obs.chain(line_obs) {
            for (kf, _) in observations {
                if map.keyframe(*kf).is_some() {
                    *votes.entry(*kf).or_insert(0) += 1;
                }
            }
        }
        let mut ranked: Vec<_> = votes.into_iter().collect();
        ranked.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(b.0.cmp(&a.0)));
        let limit = self.config.local_keyframes;
        self.local_keyframes.clear();
        self.local_keyframes
            .extend(ranked.iter().map(|(kf, _)| *kf).take(limit));
        if let Some((best, _)) = ranked.first() {
            self.reference = Some(*best);
        }
        let mut i = 0;
        while i < self.local_keyframes.len() && self.local_keyframes.len() < limit {
            let neighbours = map.covisible(self.local_keyframes[i], COVISIBILITY_MIN_SHARED);
            let held = neighbours
                .into_iter()
                .filter(|(k, _)| map.keyframe(*k).is_some());
            for (neighbour, _) in held.take(NEIGHBOURS_PER_KEYFRAME) {
                if !self.local_keyframes.contains(&neighbour) && self.local_keyframes.len() < limit
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
        self.add_view_keyframes(map, frame);
    }

    /// Adds the keyframes sharing the frame's view (`[tracking] view_keyframes`, closest
    /// first): a place the camera comes back to is in the local map at once, whether or
    /// not its keyframes are covisible with the matches yet. Only keyframes a closed
    /// loop made consistent ([`Map::closed_through`]): before, an old keyframe carries
    /// the drift of the loop, and matching its landmarks would take that drift in as a
    /// jump of the pose and hide the loop from loop closing (which looks for places
    /// not covisible with the new keyframe). The synthetic 3000-frame loop without
    /// this condition: no loop found, ATE 0.0088 against 0.0060 m.
    fn add_view_keyframes(&mut self, map: &Map, frame: &TrackedFrame) {
        let Some(closed_through) = map.closed_through() else {
            return;
        };
        if self.config.view_keyframes == 0 {
            return;
        }
        map.keyframes_sharing_view(
            &frame.camera_from_world.inverse(),
            self.config.view_radius_m,
            self.config.view_angle_deg.to_radians(),
            &mut self.view_keyframes,
        );
        let mut added = 0;
        for (_, kf) in &self.view_keyframes {
            if added == self.config.view_keyframes {
                break;
            }
            if *kf <= closed_through && !self.local_keyframes.contains(kf) {
                self.local_keyframes.push(*kf);
                added += 1;
            }
        }
    }
}
