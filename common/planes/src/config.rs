//! The `[planes]` table of the config file: pixel normals, BFS region growing, Manhattan
//! axes and line <-> axis association.

use crate::error::PlaneError;
use serde::Deserialize;

/// Parameters of the planes stage. Angles are in degrees (config convention); the code
/// converts them once when an estimator is built.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlaneConfig {
    /// Pixel stride of the normal grid (default 4): one grid node per `stride x stride`
    /// block of the depth image, so a VGA frame becomes a 160 x 120 grid. This is where
    /// the speed comes from; the BFS of Algorithm 1 runs on that grid.
    pub stride: usize,
    /// Average the valid depths of each block into its node's 3D point (default true).
    /// Reads every pixel once but divides the depth noise by up to `stride`, which the
    /// cross-product normal of Algorithm 1 needs on Kinect data (sigma = 1.425e-3 z^2).
    /// When false, the node is the single pixel at the block centre.
    pub average_blocks: bool,
    /// Largest relative depth jump per pixel of distance (default 0.015): two samples
    /// `k` pixels apart at depth `z` are continuous when `|dz| <= k * 0.015 * z`. This
    /// accepts a plane up to ~81 deg from fronto-parallel and rejects occlusion edges.
    pub max_depth_jump_per_px: f32,
    /// Largest angle between a grid node's normal and the normal of the neighbour it
    /// is reached from, for the neighbour to join the region (default 12 deg, Algorithm 1's
    /// "same direction" test between adjacent pixels).
    pub neighbour_angle_deg: f32,
    /// Largest angle between a joining node's normal and the running mean normal of
    /// the region (default 15 deg). Without it, region growing drifts around smoothly
    /// curved surfaces (a cylinder, a bent sheet) one small step at a time.
    pub region_angle_deg: f32,
    /// Smallest plane, in image pixels (grid nodes x stride^2) (default 4000, 1.3 % of a
    /// VGA frame): smaller regions are clutter for the Manhattan axes.
    pub min_plane_pixels: u32,
    /// Regions whose normals are within this angle (default 5 deg) and whose offsets
    /// agree (see `merge_offset_ratio`) are merged into one plane (a wall split by
    /// an object in front of it). 0 disables merging.
    pub merge_angle_deg: f32,
    /// Largest offset difference for merging, relative to the larger offset (default
    /// 0.05: 10 cm at 2 m).
    pub merge_offset_ratio: f32,
    /// A direction supports a Manhattan axis within this angle (default 5 deg).
    pub ma_inlier_angle_deg: f32,
    /// Two directions form a Manhattan hypothesis when they are this close to
    /// orthogonal (default 10 deg).
    pub ma_orthogonality_deg: f32,
    /// Share of the vote given to plane normals when both planes and lines are present
    /// (default 0.5); planes are weighted by pixels, lines by the caller's weights, each
    /// group normalised to its share so neither the unit nor the count of lines matters.
    pub ma_plane_share: f32,
    /// An axis counts as observed when a plane normal supports it, or when its
    /// supporting line directions carry at least this fraction of the frame's vote
    /// (default 0.05).
    pub ma_min_axis_support: f32,
    /// "No MA" when the axes are supported by less than this fraction of the frame's
    /// vote (default 0.3): the scene has no dominant orthogonal structure.
    pub ma_min_support: f32,
    /// A 3D line is associated with an axis when it is within this angle of it
    /// (default 6 deg).
    pub line_axis_angle_deg: f32,
}

impl Default for PlaneConfig {
    fn default() -> Self {
        Self {
            stride: 4,
            average_blocks: true,
            max_depth_jump_per_px: 0.015,
            neighbour_angle_deg: 12.0,
            region_angle_deg: 15.0,
            min_plane_pixels: 4000,
            merge_angle_deg: 5.0,
            merge_offset_ratio: 0.05,
            ma_inlier_angle_deg: 5.0,
            ma_orthogonality_deg: 10.0,
            ma_plane_share: 0.5,
            ma_min_axis_support: 0.05,
            ma_min_support: 0.3,
            line_axis_angle_deg: 6.0,
        }
    }
}

/// Largest stride accepted: beyond it a VGA frame has too few nodes for any plane.
const MAX_STRIDE: usize = 64;

impl PlaneConfig {
    /// Checks every field.
    ///
    /// # Errors
    /// [`PlaneError::InvalidConfig`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), PlaneError> {
        let check = |field: &'static str, value: f64, ok: bool, reason: &'static str| {
            if value.is_finite() && ok {
                Ok(())
            } else {
                Err(PlaneError::InvalidConfig {
                    field,
                    value,
                    reason,
                })
            }
        };
        let angle = |field, v: f32| {
            check(
                field,
                v.into(),
                v > 0.0 && v < 90.0,
                "must be in (0, 90) deg",
            )
        };
        check(
            "stride",
            self.stride as f64,
            (1..=MAX_STRIDE).contains(&self.stride),
            "must be in 1..=64",
        )?;
        check(
            "max_depth_jump_per_px",
            self.max_depth_jump_per_px.into(),
            self.max_depth_jump_per_px > 0.0,
            "must be > 0",
        )?;
        angle("neighbour_angle_deg", self.neighbour_angle_deg)?;
        angle("region_angle_deg", self.region_angle_deg)?;
        check(
            "merge_angle_deg",
            self.merge_angle_deg.into(),
            (0.0..90.0).contains(&self.merge_angle_deg),
            "must be in [0, 90) deg",
        )?;
        check(
            "merge_offset_ratio",
            self.merge_offset_ratio.into(),
            self.merge_offset_ratio >= 0.0,
            "must be >= 0",
        )?;
        angle("ma_inlier_angle_deg", self.ma_inlier_angle_deg)?;
        angle("ma_orthogonality_deg", self.ma_orthogonality_deg)?;
        for (field, v) in [
            ("ma_plane_share", self.ma_plane_share),
            ("ma_min_axis_support", self.ma_min_axis_support),
            ("ma_min_support", self.ma_min_support),
        ] {
            check(
                field,
                v.into(),
                (0.0..=1.0).contains(&v),
                "must be in [0, 1]",
            )?;
        }
        angle("line_axis_angle_deg", self.line_axis_angle_deg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_toml_table_sets_some_fields_and_rejects_unknown_ones() {
        let c: PlaneConfig = toml::from_str("stride = 2\nregion_angle_deg = 10.0\n").unwrap();
        assert_eq!((c.stride, c.region_angle_deg), (2, 10.0));
        assert_eq!(c.min_plane_pixels, PlaneConfig::default().min_plane_pixels);
        let e = toml::from_str::<PlaneConfig>("strid = 2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("strid"), "{e}");
    }

    #[test]
    fn defaults_are_valid_and_bad_fields_are_named() {
        assert!(PlaneConfig::default().validate().is_ok());
        let bad = PlaneConfig {
            stride: 0,
            ..PlaneConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("stride"), "{e}");
        let bad = PlaneConfig {
            region_angle_deg: f32::NAN,
            ..PlaneConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("region_angle_deg"), "{e}");
    }
}
