//! Range and relation checks of the odometry's config tables (`[tracking]`,
//! `[keyframes]`, `[mapping]`, `[mapping.ba]`), run when a config is read, so that a
//! value that would make every frame fail is an error naming its field.

use crate::config::{
    KeyframeConfig, LoopClosingConfig, MappingConfig, OdometryConfig, TrackingConfig,
};
use crate::frontend::features::FrameFeatures;
use gfs_core::fields::{FieldError, Table};
use gfs_optim::BaConfig;

/// Hamming distances are of 256-bit descriptors.
const DESCRIPTOR_BITS: u64 = 256;
/// Largest `[keyframes] max_keyframes`: the whole map is one message (the loop stage's,
/// the mapper's checkpoint) of at most 64 MB, about 700 keyframes of 90 KB.
const MAX_KEYFRAMES_CAP: usize = 600;

impl OdometryConfig {
    /// Checks every table.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        self.tracking.validate()?;
        self.keyframes.validate()?;
        self.mapping.validate()?;
        self.loop_closing.validate()
    }
}

impl FrameFeatures {
    /// True when the frame has no point, no line, no plane and no depth: its images
    /// were unreadable (the pipeline's source publishes a blank frame for them) or show
    /// nothing. Every mode gives such a frame the motion-model prediction without
    /// trying to track it. A bare wall's depth is not blank: with the depth alignment
    /// or the planes on it can be tracked.
    pub fn is_blank(&self) -> bool {
        self.keypoints.is_empty()
            && self.lines.is_empty()
            && self.planes.is_empty()
            && !self.depth.has_depth()
    }
}

impl TrackingConfig {
    /// Checks `[tracking]` and its `points` / `lines` / `depth` / `planes` sub-tables.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        let t = Table("tracking");
        t.at_least("min_inliers", self.min_inliers as u64, 3)?;
        t.require(
            "degraded_inliers",
            self.degraded_inliers,
            self.degraded_inliers >= self.min_inliers,
            "at least tracking.min_inliers",
        )?;
        t.at_least("local_keyframes", self.local_keyframes as u64, 1)?;
        t.positive("view_radius_m", self.view_radius_m)?;
        t.within("view_angle_deg", self.view_angle_deg, 0.0, 180.0)?;
        t.at_least(
            "frames_before_new_map",
            self.frames_before_new_map.into(),
            1,
        )?;
        t.at_least("min_initial_points", self.min_initial_points as u64, 3)?;
        t.positive("close_depth_m", self.close_depth_m.into())?;
        let p = Table("tracking.points");
        p.within("max_distance", self.points.max_distance.into(), 0.0, 256.0)?;
        p.fraction("ratio", self.points.ratio.into())?;
        p.positive("radius_last_frame", self.points.radius_last_frame)?;
        p.positive("radius_local_map", self.points.radius_local_map)?;
        let l = Table("tracking.lines");
        l.require(
            "max_distance",
            self.lines.max_distance,
            u64::from(self.lines.max_distance) <= DESCRIPTOR_BITS,
            "in [0, 256]",
        )?;
        l.fraction("ratio", self.lines.ratio.into())?;
        l.within("max_angle_deg", self.lines.max_angle_deg.into(), 0.0, 90.0)?;
        l.positive("max_offset_px", self.lines.max_offset_px.into())?;
        let d = Table("tracking.depth");
        d.at_least("source_step", self.depth.source_step as u64, 1)?;
        d.require(
            "max_distance_m",
            format!("{:?}", self.depth.max_distance_m),
            !self.depth.max_distance_m.is_empty()
                && self
                    .depth
                    .max_distance_m
                    .iter()
                    .all(|g| *g > 0.0 && g.is_finite()),
            "one or more positive distances",
        )?;
        d.require(
            "registration_distance_m",
            format!("{:?}", self.depth.registration_distance_m),
            (self.depth.registration_distance_m.iter())
                .all(|g| *g > self.depth.occlusion_m() && g.is_finite()),
            "distances beyond the first of tracking.depth.max_distance_m (none: no coarse \
             registration)",
        )?;
        d.within(
            "max_normal_angle_deg",
            self.depth.max_normal_angle_deg,
            0.0,
            90.0,
        )?;
        d.positive("lever_arm_m", self.depth.lever_arm_m)?;
        d.positive("max_sigma_m", self.depth.max_sigma_m)?;
        d.not_below(
            "independent_pixels_per_node",
            self.depth.independent_pixels_per_node,
            1.0,
        )?;
        d.not_below("weak_sigma_m", self.depth.weak_sigma_m, 0.0)?;
        d.not_below("renewal_sigma_m", self.depth.renewal_sigma_m, 0.0)?;
        d.positive("renewal_own_sigma_m", self.depth.renewal_own_sigma_m)?;
        d.fraction("renewal_overlap", self.depth.renewal_overlap)?;
        d.fraction("renewal_floor_overlap", self.depth.renewal_floor_overlap)?;
        d.not_below("photometric_sigma", self.depth.photometric_sigma, 0.0)?;
        d.not_below(
            "photometric_position_sigma_px",
            self.depth.photometric_position_sigma_px,
            0.0,
        )?;
        for (field, value) in [
            (
                "motion_prior_accel_m_s2",
                self.depth.motion_prior_accel_m_s2,
            ),
            (
                "motion_prior_angular_accel_deg_s2",
                self.depth.motion_prior_angular_accel_deg_s2,
            ),
            (
                "motion_prior_feature_angular_accel_deg_s2",
                self.depth.motion_prior_feature_angular_accel_deg_s2,
            ),
            (
                "motion_prior_velocity_accel_m_s2",
                self.depth.motion_prior_velocity_accel_m_s2,
            ),
            (
                "motion_prior_angular_rate_accel_deg_s2",
                self.depth.motion_prior_angular_rate_accel_deg_s2,
            ),
        ] {
            d.not_below(field, value, 0.0)?;
        }
        let q = Table("tracking.planes");
        q.within(
            "max_normal_angle_deg",
            self.planes.max_normal_angle_deg,
            0.0,
            90.0,
        )?;
        q.positive("max_offset_m", self.planes.max_offset_m)?;
        q.positive("normal_sigma_deg", self.planes.normal_sigma_deg)?;
        q.positive("offset_sigma_scale", self.planes.offset_sigma_scale)
    }
}

impl KeyframeConfig {
    /// Checks `[keyframes]`.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        let t = Table("keyframes");
        t.at_least("max_frames", self.max_frames.into(), 1)?;
        t.fraction("point_ratio", self.point_ratio.into())?;
        t.fraction("line_ratio", self.line_ratio.into())?;
        t.fraction(
            "redundant_point_fraction",
            self.redundant_point_fraction.into(),
        )?;
        t.fraction(
            "redundant_line_fraction",
            self.redundant_line_fraction.into(),
        )?;
        t.at_least("redundant_observers", self.redundant_observers as u64, 1)?;
        t.at_least("revisit_observers", self.revisit_observers as u64, 1)?;
        t.require(
            "revisit_observers",
            self.revisit_observers as f64,
            self.revisit_observers <= self.redundant_observers,
            "at most redundant_observers",
        )?;
        t.require(
            "max_keyframes",
            self.max_keyframes,
            (2..=MAX_KEYFRAMES_CAP).contains(&self.max_keyframes),
            &format!("in [2, {MAX_KEYFRAMES_CAP}]"),
        )
    }
}

impl MappingConfig {
    /// Checks `[mapping]` and `[mapping.ba]`.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        let t = Table("mapping");
        t.at_least("ba_keyframes", self.ba_keyframes as u64, 1)?;
        t.at_least("tracker_keyframes", self.tracker_keyframes as u64, 1)?;
        t.within("structural_angle_deg", self.structural_angle_deg, 0.0, 45.0)?;
        t.within("manhattan_angle_deg", self.manhattan_angle_deg, 0.0, 45.0)?;
        t.within(
            "plane_structure_angle_deg",
            self.plane_structure_angle_deg,
            0.0,
            45.0,
        )?;
        t.require(
            "fuse_max_distance",
            self.fuse_max_distance,
            u64::from(self.fuse_max_distance) <= DESCRIPTOR_BITS,
            "in [0, 256]",
        )?;
        validate_ba(&self.ba)
    }
}

impl LoopClosingConfig {
    /// Checks `[loop_closing]`.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        let t = Table("loop_closing");
        t.at_least("min_keyframe_gap", self.min_keyframe_gap, 1)?;
        t.positive("search_radius_m", self.search_radius_m)?;
        t.within("search_angle_deg", self.search_angle_deg, 0.0, 180.0)?;
        t.at_least("max_candidates", self.max_candidates as u64, 1)?;
        t.at_least("consistent_keyframes", self.consistent_keyframes.into(), 1)?;
        t.at_least("min_inliers", self.min_inliers as u64, 6)?;
        t.positive("max_sigma_m", self.max_sigma_m)
    }
}

fn validate_ba(ba: &BaConfig) -> Result<(), FieldError> {
    let t = Table("mapping.ba");
    t.within(
        "first_pass_iterations",
        ba.first_pass_iterations as f64,
        0.0,
        1000.0,
    )?;
    t.within(
        "second_pass_iterations",
        ba.second_pass_iterations as f64,
        0.0,
        1000.0,
    )?;
    t.not_below("settled_step_m", ba.settled_step_m, 0.0)?;
    t.not_below("settled_step_rad", ba.settled_step_rad, 0.0)?;
    for (name, value) in [
        ("point_chi2", ba.point_chi2),
        ("point_depth_chi2", ba.point_depth_chi2),
        ("bf", ba.bf),
        ("inverse_depth_sigma", ba.inverse_depth_sigma),
        ("line_chi2", ba.line_chi2),
        ("parallel_chi2", ba.parallel_chi2),
        ("perpendicular_chi2", ba.perpendicular_chi2),
        ("manhattan_chi2", ba.manhattan_chi2),
        ("plane_chi2", ba.plane_chi2),
    ] {
        t.positive(name, value)?;
    }
    for (name, value) in [
        ("parallel_weight", ba.parallel_weight),
        ("perpendicular_weight", ba.perpendicular_weight),
        ("manhattan_weight", ba.manhattan_weight),
    ] {
        t.not_below(name, value, 0.0)?;
    }
    // 0 turns the plane structural terms off; 45 degrees would let any pair pass.
    t.within(
        "plane_structure_sigma_deg",
        ba.plane_structure_sigma_deg,
        0.0,
        45.0,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_name_their_field() {
        assert_eq!(OdometryConfig::default().validate(), Ok(()));
        let mut c = OdometryConfig::default();
        c.tracking.degraded_inliers = c.tracking.min_inliers - 1;
        let e = c.validate().unwrap_err();
        assert_eq!(e.field, "tracking.degraded_inliers");
        let mut c = OdometryConfig::default();
        c.keyframes.point_ratio = 0.0;
        assert_eq!(c.validate().unwrap_err().field, "keyframes.point_ratio");
        // The safety cap keeps the whole map one message.
        let mut c = OdometryConfig::default();
        c.keyframes.max_keyframes = 100_000;
        assert_eq!(c.validate().unwrap_err().field, "keyframes.max_keyframes");
        let mut c = OdometryConfig::default();
        c.mapping.tracker_keyframes = 0;
        assert_eq!(c.validate().unwrap_err().field, "mapping.tracker_keyframes");
        let mut c = OdometryConfig::default();
        c.tracking.view_angle_deg = 200.0;
        assert_eq!(c.validate().unwrap_err().field, "tracking.view_angle_deg");
        let mut c = OdometryConfig::default();
        c.mapping.ba.inverse_depth_sigma = f64::NAN;
        assert_eq!(
            c.validate().unwrap_err().field,
            "mapping.ba.inverse_depth_sigma"
        );
        let mut c = OdometryConfig::default();
        c.tracking.lines.ratio = 1.5;
        assert_eq!(c.validate().unwrap_err().field, "tracking.lines.ratio");
        let mut c = OdometryConfig::default();
        c.tracking.depth.max_distance_m.clear();
        assert_eq!(
            c.validate().unwrap_err().field,
            "tracking.depth.max_distance_m"
        );
        let mut c = OdometryConfig::default();
        c.tracking.depth.independent_pixels_per_node = 0.5;
        assert_eq!(
            c.validate().unwrap_err().field,
            "tracking.depth.independent_pixels_per_node"
        );
        let mut c = OdometryConfig::default();
        c.tracking.depth.weak_sigma_m = -1.0;
        assert_eq!(
            c.validate().unwrap_err().field,
            "tracking.depth.weak_sigma_m"
        );
        let mut c = OdometryConfig::default();
        c.loop_closing.search_radius_m = -1.0;
        assert_eq!(
            c.validate().unwrap_err().field,
            "loop_closing.search_radius_m"
        );
        let mut c = OdometryConfig::default();
        c.tracking.depth.motion_prior_accel_m_s2 = f64::INFINITY;
        assert_eq!(
            c.validate().unwrap_err().field,
            "tracking.depth.motion_prior_accel_m_s2"
        );
    }

    #[test]
    fn a_bare_wall_is_not_a_blank_frame_an_unreadable_one_is() {
        use crate::testing::{camera, planes_depth};
        use nalgebra::Isometry3;
        // No point, no line: a wall 2 m ahead, seen by depth only.
        let wall = FrameFeatures {
            depth: planes_depth(&camera(), &Isometry3::identity(), &[([0.0, 0.0, 1.0], 2.0)]),
            ..FrameFeatures::default()
        };
        assert!(wall.depth.points.iter().filter(|p| p[2] > 0.0).count() > 1000);
        assert!(!wall.is_blank());
        // An unreadable frame: its grid has nodes but no depth.
        let mut unreadable = wall.clone();
        unreadable
            .depth
            .points
            .iter_mut()
            .for_each(|p| *p = [0.0; 3]);
        assert!(unreadable.is_blank());
        assert!(FrameFeatures::default().is_blank());
    }
}
