//! The plane term of tracking (`[tracking] use_planes`): the frame's BFS planes paired
//! with the map's planes at the current estimate, as plane-to-plane errors of the pose
//! optimisation.

use super::{TrackedFrame, Tracker};
use crate::map::Map;

impl Tracker {
    /// Pairs the frame's planes with the map's at its current pose and sets them on the
    /// solver for the next optimisations (until [`Self::clear_planes`]); the pairs are
    /// recorded in the frame's `plane_ids`. Returns true when they differ from the pairs
    /// set before.
    pub(super) fn pair_planes(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        let (observations, pairs) = self.plane_associator.associate(
            &self.config.planes,
            &frame.features.planes,
            &frame.camera_from_world,
            map,
        );
        let changed = self.plane_pairs != pairs;
        self.solver.set_planes(observations);
        self.plane_pairs.clear();
        self.plane_pairs.extend_from_slice(pairs);
        frame.plane_ids.iter_mut().for_each(|p| *p = None);
        for (i, id) in pairs {
            if let Some(slot) = frame.plane_ids.get_mut(*i) {
                *slot = Some(*id);
            }
        }
        changed
    }

    /// Keeps in the frame's `plane_ids` the pairs the last optimisation kept as inliers.
    pub(super) fn keep_plane_inliers(&self, frame: &mut TrackedFrame) {
        for ((i, _), inlier) in self.plane_pairs.iter().zip(self.solver.plane_inliers()) {
            if !inlier && let Some(slot) = frame.plane_ids.get_mut(*i) {
                *slot = None;
            }
        }
    }

    /// Removes the plane observations from the solver.
    pub(super) fn clear_planes(&mut self) {
        self.solver.set_planes(&[]);
        self.plane_pairs.clear();
    }

    /// Re-optimises a frame tracked on features with its planes added: associated at the
    /// feature pose and optimised, then associated again at the refined pose (a plane the
    /// first pose put outside the gates may now be within) and optimised again if that
    /// changed the pairs (the same pairs would find the same optimum again). The planes
    /// stay set on the solver.
    pub(super) fn refine_with_planes(&mut self, map: &Map, frame: &mut TrackedFrame) {
        self.plane_pairs.clear();
        for _ in 0..PLANE_PASSES {
            if !self.pair_planes(map, frame) || self.plane_pairs.is_empty() {
                break;
            }
            self.optimise(map, frame);
        }
        self.keep_plane_inliers(frame);
    }
}

/// Association + optimisation passes of the plane term.
const PLANE_PASSES: usize = 2;

#[cfg(test)]
mod tests {
    use crate::config::TrackingConfig;
    use crate::frontend::features::FrameFeatures;
    use crate::testing::{CORNER, camera, plane_map, planes_of, scale};
    use crate::tracking::plane_association::PlaneTrackingConfig;
    use crate::tracking::sightings::Sightings;
    use crate::tracking::status::TrackingStatus;
    use crate::tracking::tracker::{TrackedFrame, Tracker};
    use gfs_core::ids::FrameId;
    use gfs_lines::grid::GridConfig;
    use nalgebra::{Isometry3, Vector6};

    /// Planes measured exactly: their weights those of planes fitted to 0.25 degrees
    /// and a quarter of the depth noise.
    fn config() -> TrackingConfig {
        TrackingConfig {
            use_planes: true,
            planes: PlaneTrackingConfig {
                normal_sigma_deg: 0.25,
                offset_sigma_scale: 0.25,
                ..PlaneTrackingConfig::default()
            },
            ..TrackingConfig::default()
        }
    }

    fn tracker() -> Tracker {
        Tracker::new(config(), camera(), scale(), &GridConfig::default())
    }

    fn frame(
        k: u64,
        camera_from_world: &Isometry3<f64>,
        planes: &[([f64; 3], f64)],
    ) -> FrameFeatures {
        FrameFeatures {
            id: FrameId(k),
            timestamp: crate::testing::frame_stamp(k),
            planes: planes_of(camera_from_world, planes),
            ..FrameFeatures::default()
        }
    }

    #[test]
    fn three_map_planes_alone_track_frame_after_frame() {
        // No point, no line, no depth: the map's floor and two walls, the camera moving
        // 1 cm and 0.6 degrees per frame about a tilted axis.
        let (map, kf) = plane_map(&CORNER);
        assert_eq!(map.planes().len(), 3);
        let mut tracker = tracker();
        tracker.set_reference(kf);
        let step = gfs_core::se3::exp(&Vector6::new(0.01, -0.004, 0.006, 0.004, 0.008, -0.005));
        let mut truth = Isometry3::identity();
        let mut first = TrackedFrame::untracked(frame(0, &truth, &CORNER), truth);
        first.status = TrackingStatus::Tracked;
        tracker.finish_frame(first);
        let mut sightings = Sightings::default();
        for k in 1..8 {
            truth = step * truth;
            let tracked = tracker.track(&map, frame(k, &truth, &CORNER), &mut sightings);
            let error = tracked.camera_from_world * truth.inverse();
            assert_eq!(tracked.status, TrackingStatus::Tracked, "frame {k}");
            assert_eq!(tracked.inliers.planes, 3, "frame {k}");
            assert!(tracked.plane_ids.iter().all(Option::is_some), "frame {k}");
            assert!(error.translation.vector.norm() < 1e-3, "frame {k}: {error}");
            assert!(error.rotation.angle() < 0.1f64.to_radians(), "frame {k}");
            tracker.finish_frame(tracked);
        }
    }

    #[test]
    fn two_parallel_walls_leave_a_frame_on_planes_degraded() {
        // A corridor's two walls leave its axis, the vertical and the roll free: the
        // frame is `degraded` (the motion prior holds what they leave free).
        let walls = [([1.0, 0.0, 0.0], -1.0), ([1.0, 0.0, 0.0], 1.0)];
        let (map, kf) = plane_map(&walls);
        let mut tracker = tracker();
        tracker.set_reference(kf);
        let start = Isometry3::identity();
        let mut first = TrackedFrame::untracked(frame(0, &start, &walls), start);
        first.status = TrackingStatus::Tracked;
        tracker.finish_frame(first);
        let moved = Isometry3::translation(0.0, 0.0, -0.02);
        let tracked = tracker.track(&map, frame(1, &moved, &walls), &mut Sightings::default());
        assert_eq!(tracked.status, TrackingStatus::Degraded);
        let constraint = gfs_optim::analyse_constraint(
            &crate::tracking::plane_association::self_information(
                &config().planes,
                &planes_of(&moved, &walls),
            ),
            2.0,
            0.01,
        );
        // Free: along the corridor (z), up (y) and the roll about the walls' normal (x).
        assert_eq!(constraint.unconstrained.len(), 3, "{constraint:?}");
        for d in &constraint.unconstrained {
            assert!(
                d[0].abs() < 1e-6 && d[4].abs() < 1e-6 && d[5].abs() < 1e-6,
                "{d}"
            );
        }
    }
}
