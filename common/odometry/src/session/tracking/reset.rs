//! A new map on request (an operator's or a robot's reset): the map tracked against is
//! abandoned and the next frame with enough depth starts another, as after a long
//! outage, but from where the camera is now (or from a pose the caller gives).

use super::TrackingSession;
use crate::frontend::features::FrameFeatures;
use crate::map::manhattan::WorldManhattan;
use crate::session::state::TrackingState;
use crate::tracking::sightings::Sightings;
use crate::tracking::tracker::TrackedFrame;
use nalgebra::Isometry3;

/// Why a reset was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ResetError {
    /// Localising in a fixed map (`LoadedMapUse::localise`): the map is not to change.
    #[error("the map is fixed (localisation in a loaded map): it is not reset")]
    FixedMap,
    /// A keyframe or relocalisation request waits for its map: its answer would bring
    /// the old map back. Reset once it came.
    #[error("a map request is waiting for its answer")]
    RequestPending,
}

impl TrackingSession {
    /// Abandons the map: the next frame with enough keypoints with depth starts a new
    /// one, and its keyframe request tells the mapping half to drop the old one. That
    /// frame is first tracked against the old map, so the new map starts where the
    /// camera is and the published odometry goes on without a jump; with
    /// `world_from_camera` (odometry frame) the camera is placed there instead, at rest,
    /// and the odometry goes on from that pose. The new map's frame is the odometry
    /// frame (`map_from_odom` becomes the identity). Call between frames.
    ///
    /// # Errors
    /// [`ResetError`] when localising in a fixed map or while a request waits for its
    /// map; nothing changes then.
    pub fn start_new_map(
        &mut self,
        world_from_camera: Option<Isometry3<f64>>,
    ) -> Result<(), ResetError> {
        if self.saved.fixed {
            return Err(ResetError::FixedMap);
        }
        if self.requests.pending().is_some() {
            return Err(ResetError::RequestPending);
        }
        match world_from_camera {
            None => self.dropped = Some(self.map.clone()),
            Some(pose) => {
                self.odometry_becomes_world();
                let timestamp = self
                    .tracker
                    .last_frame()
                    .map(|f| f.features.timestamp)
                    .unwrap_or_default();
                let features = FrameFeatures {
                    timestamp,
                    ..FrameFeatures::default()
                };
                self.tracker
                    .relocalised(TrackedFrame::untracked(features, pose.inverse()));
            }
        }
        self.map.clear_keyframes();
        self.manhattan = WorldManhattan::new(self.config.tracking.use_manhattan);
        self.sightings = Sightings::default();
        self.relocalising = None;
        self.relocalised = None;
        self.requested_pose = None;
        self.saved = super::saved_map::OnSavedMap::default();
        self.frames_since_keyframe = 0;
        self.state = TrackingState::NoMap { reset: true };
        Ok(())
    }

    /// Where the first frame after [`Self::start_new_map`] starts the new map
    /// (`camera_from_world`, odometry frame): tracked against the map dropped, else
    /// predicted. `None` when no map was dropped (a reset to a pose, a long outage).
    pub(super) fn pose_on_dropped_map(
        &mut self,
        features: &FrameFeatures,
    ) -> Option<Isometry3<f64>> {
        let dropped = self.dropped.take()?;
        let frame = self
            .tracker
            .track(&dropped, features.clone(), &mut Sightings::default());
        let in_map = if frame.status.is_tracked() {
            frame.camera_from_world
        } else {
            self.tracker.predict().unwrap_or_else(Isometry3::identity)
        };
        let map_from_odom = self.map_from_odom;
        self.odometry_becomes_world();
        Some(in_map * map_from_odom)
    }

    /// Re-expresses the last frame and the motion model in the odometry frame (published
    /// poses are `map_from_odom^-1 * map pose`), which a new map is built in.
    fn odometry_becomes_world(&mut self) {
        self.tracker.shift_world(&self.map_from_odom.inverse());
        self.map_from_odom = Isometry3::identity();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::session::{FramePose, MappingSession};
    use crate::testing::{Scene, camera, pose};
    use gfs_lines::grid::GridConfig;

    /// The camera moves 1 cm right and turns 0.2 degrees per frame (`camera_from_world`).
    fn truth(k: u64) -> Isometry3<f64> {
        pose(0.01 * k as f64, (0.2f64 * k as f64).to_radians())
    }

    struct Run {
        tracking: TrackingSession,
        mapping: MappingSession,
        scene: Scene,
    }

    impl Run {
        fn new() -> Self {
            let config = OdometryConfig::default();
            Self {
                tracking: TrackingSession::new(
                    config.clone(),
                    camera(),
                    1.2,
                    8,
                    &GridConfig::default(),
                ),
                mapping: MappingSession::new(&config, camera(), 1.2, 8),
                scene: Scene::new(200, 20),
            }
        }

        /// Tracks frame `k`, answering a keyframe request at once; the pose and whether
        /// the frame started a map in place of another.
        fn step(&mut self, k: u64) -> (FramePose, bool) {
            let out = self
                .tracking
                .process(self.scene.features(k, &truth(k)))
                .expect("consistent features");
            let reset = out.keyframe.as_ref().is_some_and(|r| r.reset);
            if let Some(request) = out.keyframe {
                assert!(self.tracking.apply(self.mapping.insert(request)));
            }
            (out.pose, reset)
        }
    }

    fn gap_m(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
        (a.translation.vector - b.translation.vector).norm()
    }

    #[test]
    fn a_reset_starts_a_new_map_and_the_odometry_goes_on_from_the_last_pose() {
        let mut run = Run::new();
        for k in 0..20 {
            assert!(run.step(k).0.status.is_tracked(), "frame {k}");
        }
        let before = run.mapping.map().keyframe_count();
        run.tracking
            .start_new_map(None)
            .expect("no request pending");
        assert_eq!(run.tracking.state(), TrackingState::NoMap { reset: true });
        // Frames 20 to 23 are dropped (a realtime tracker behind): a prediction from
        // frame 19 would be 4 cm off; frame 24 is tracked on the old map first.
        let (pose, reset) = run.step(24);
        assert!(reset && pose.status.is_tracked(), "frame 24 starts the map");
        assert_eq!(
            run.mapping.map().keyframe_count(),
            1,
            "the {before} keyframes of the old map were dropped"
        );
        let step_m = gap_m(&pose.world_from_camera, &truth(24).inverse());
        assert!(step_m < 1e-3, "the odometry jumped {step_m} m at the reset");
        for k in 25..35 {
            let (pose, _) = run.step(k);
            let error_m = gap_m(&pose.world_from_camera, &truth(k).inverse());
            assert!(
                pose.status.is_tracked() && error_m < 1e-3,
                "frame {k}: {error_m} m"
            );
        }
    }

    #[test]
    fn a_reset_to_a_pose_goes_on_from_that_pose() {
        let mut run = Run::new();
        for k in 0..10 {
            run.step(k);
        }
        let given = Isometry3::translation(2.0, 0.0, -1.0);
        run.tracking.start_new_map(Some(given)).expect("no request");
        let (pose, reset) = run.step(10);
        assert!(reset && pose.status.is_tracked());
        assert!(gap_m(&pose.world_from_camera, &given) < 1e-9);
        // The camera moves on as before, now from the given pose.
        let (pose, _) = run.step(11);
        let moved = truth(10) * truth(11).inverse();
        let error_m = gap_m(&pose.world_from_camera, &(given * moved));
        assert!(error_m < 1e-3, "{error_m} m from the given pose's path");
    }

    #[test]
    fn a_reset_waits_for_the_pending_map_request() {
        let mut run = Run::new();
        let out = run
            .tracking
            .process(run.scene.features(0, &truth(0)))
            .expect("features");
        assert!(out.keyframe.is_some());
        assert_eq!(
            run.tracking.start_new_map(None),
            Err(ResetError::RequestPending)
        );
        assert_eq!(run.tracking.state(), TrackingState::Tracking, "unchanged");
    }
}
