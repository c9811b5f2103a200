//! The in-process odometry with its front end, fed rendered synthetic frames (the
//! accuracy, loop-closure and relocalisation tests).

use gfs_core::camera::PinholeCamera;
use gfs_core::ids::FrameId;
use gfs_lines::extractor::LineConfig;
use gfs_odometry::{FramePose, Frontend, Odometry, OdometryConfig};
use gfs_planes::PlaneConfig;
use gfs_points::OrbConfig;
use gfs_synth::SynthFrame;

/// A front end and an odometry with the default extractor settings.
pub struct InProcess {
    pub frontend: Frontend,
    pub odometry: Odometry,
}

impl InProcess {
    /// For `camera`, the front end keeping what `config`'s switches use.
    pub fn new(camera: PinholeCamera, config: OdometryConfig) -> Self {
        let (points, lines) = (OrbConfig::default(), LineConfig::default());
        let mut frontend = Frontend::new(
            camera,
            &points,
            &lines,
            &PlaneConfig::default(),
            config.tracking.use_lines,
            config.tracking.use_manhattan,
        )
        .unwrap();
        frontend.set_keep_depth(config.tracking.use_depth_alignment);
        frontend.set_keep_planes(config.tracking.use_planes);
        let odometry = Odometry::new(
            config,
            camera,
            f64::from(points.scale_factor),
            points.levels as u8,
            &lines.grid,
        );
        Self { frontend, odometry }
    }

    /// Extracts the features of frame `i` and tracks them.
    pub fn process(&mut self, i: usize, frame: &SynthFrame) -> FramePose {
        let rotation = self.odometry.predicted_rotation();
        let features = self
            .frontend
            .extract(
                FrameId(i as u64),
                frame.timestamp,
                frame.gray.view(),
                frame.depth.view(),
                rotation.as_ref(),
            )
            .unwrap();
        self.odometry.process(features).unwrap()
    }
}
