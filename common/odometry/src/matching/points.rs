//! Point matching by projection (ORB-SLAM2's `SearchByProjection`): a map point is
//! projected with the predicted pose and compared only with the keypoints of the grid
//! cells within a scale-dependent radius, at the pyramid levels its distance predicts.

use crate::frame::{FrameFeatures, hamming};
use crate::map::Map;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::MapPointId;
use gfs_points::{KeyPointGrid, RotationHistogram};
use nalgebra::{Isometry3, Point3};
use serde::Deserialize;

/// Thresholds of point matching by projection.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PointMatchConfig {
    /// Largest Hamming distance of a match. Default 100 (ORB-SLAM2 `TH_HIGH`).
    pub max_distance: u32,
    /// Best / second-best distance ratio when both are at the same level. Default 0.8.
    pub ratio: f32,
    /// Search radius at level 0 when tracking the last frame, pixels (scaled by the
    /// level's scale). Default 15 (ORB-SLAM2, RGB-D).
    pub radius_last_frame: f64,
    /// Search radius factor when tracking the local map (ORB-SLAM2 `SearchLocalPoints`
    /// `th`: 3 for RGB-D); the radius at level 0 is this times 2.5 px for a point seen
    /// within 3.6 degrees of its mean viewing direction, 4 px otherwise
    /// (`RadiusByViewingCos`). Default 3.
    pub radius_local_map: f64,
    /// Keep only matches whose orientation change agrees with the three dominant ones
    /// (rotation-consistency histogram). Default true.
    pub check_orientation: bool,
}

impl Default for PointMatchConfig {
    fn default() -> Self {
        Self {
            max_distance: 100,
            ratio: 0.8,
            radius_last_frame: 15.0,
            radius_local_map: 3.0,
            check_orientation: true,
        }
    }
}

/// ORB-SLAM2 `RadiusByViewingCos`: a point seen within this cosine of its mean viewing
/// direction (3.6 degrees) is searched in a smaller radius, pixels at level 0.
const CLOSE_VIEW_COS: f64 = 0.998;
const CLOSE_VIEW_RADIUS_PX: f64 = 2.5;
const WIDE_VIEW_RADIUS_PX: f64 = 4.0;

/// A map point to look for, with the keypoint angle it was seen at (for the
/// orientation check), if known.
#[derive(Clone, Copy, Debug)]
pub struct ProjectionCandidate {
    /// The map point.
    pub id: MapPointId,
    /// Orientation of the keypoint that last observed it, radians.
    pub angle: Option<f32>,
}

/// Matches map points to keypoints of the current frame by projection.
#[derive(Debug, Default)]
pub struct PointProjectionMatcher {
    nearby: Vec<usize>,
    best: Vec<u32>,
    histogram: RotationHistogram,
    rejected: Vec<usize>,
}

impl PointProjectionMatcher {
    /// Projects each candidate with `camera_from_world` and links it to the closest
    /// free keypoint within `radius` (level 0 pixels, scaled per level; with
    /// `by_viewing_angle`, `radius` is a factor of ORB-SLAM2's `RadiusByViewingCos`). `matches[i]`
    /// is set for keypoint `i`; already set entries are kept. Returns the number of new
    /// matches. Candidates not in front of the camera, outside the image, or out of
    /// their scale range are skipped; each candidate that projects into the image counts
    /// as "visible" in the map statistics when `count_visible` is set.
    #[allow(clippy::too_many_arguments)]
    pub fn search(
        &mut self,
        map: &mut Map,
        candidates: &[ProjectionCandidate],
        camera_from_world: &Isometry3<f64>,
        camera: &PinholeCamera,
        frame: &FrameFeatures,
        grid: &KeyPointGrid,
        scale: &ScalePyramid,
        radius: f64,
        by_viewing_angle: bool,
        config: &PointMatchConfig,
        count_visible: bool,
        matches: &mut [Option<MapPointId>],
    ) -> usize {
        let n = frame.keypoints.len().min(matches.len());
        self.best.clear();
        self.best.resize(n, u32::MAX);
        self.histogram.clear();
        let world_from_camera = camera_from_world.inverse();
        let centre = Point3::from(world_from_camera.translation.vector);
        let mut found = 0;
        for candidate in candidates {
            let Some(point) = map.point_mut(candidate.id) else {
                continue;
            };
            let p_c = camera_from_world * point.position;
            let Some(uv) = camera.project(&p_c) else {
                continue;
            };
            if !camera.contains(uv.x, uv.y, 0.0) {
                continue;
            }
            let to_point = point.position - centre;
            let distance = to_point.norm();
            if distance < 0.8 * point.min_distance || distance > 1.2 * point.max_distance {
                continue;
            }
            // Seen from far more than 60 degrees off its mean view: appearance changed.
            if to_point.dot(&point.normal) > -0.5 * distance {
                continue;
            }
            if count_visible {
                point.visible += 1;
            }
            let level = point.predict_level(distance, scale.log_scale, scale.levels);
            let view_radius = if !by_viewing_angle {
                1.0
            } else if -to_point.dot(&point.normal) > CLOSE_VIEW_COS * distance {
                CLOSE_VIEW_RADIUS_PX
            } else {
                WIDE_VIEW_RADIUS_PX
            };
            let level_radius = radius * view_radius * scale.factor(level);
            let (min_level, max_level) = (level.saturating_sub(1), level + 1);
            grid.features_in_area(
                uv.x as f32,
                uv.y as f32,
                level_radius as f32,
                u32::from(min_level),
                u32::from(max_level),
                &mut self.nearby,
            );
            let (mut best, mut second, mut best_index) = (u32::MAX, u32::MAX, usize::MAX);
            let (mut best_level, mut second_level) = (0, 0);
            for &i in &self.nearby {
                if i >= n || matches[i].is_some() {
                    continue;
                }
                let d = hamming(&point.descriptor, &frame.point_descriptors[i]);
                let kp_level = frame.keypoints[i].level;
                if d < best {
                    (second, second_level) = (best, best_level);
                    (best, best_level, best_index) = (d, kp_level, i);
                } else if d < second {
                    (second, second_level) = (d, kp_level);
                }
            }
            if best > config.max_distance
                || best_index == usize::MAX
                || best >= self.best[best_index]
            {
                continue;
            }
            if best_level == second_level
                && second != u32::MAX
                && best as f32 > config.ratio * second as f32
            {
                continue;
            }
            self.best[best_index] = best;
            if matches[best_index].is_none() {
                found += 1;
            }
            matches[best_index] = Some(candidate.id);
            if let Some(angle) = candidate.angle {
                self.histogram
                    .add(angle, frame.keypoints[best_index].angle, best_index);
            }
        }
        if config.check_orientation {
            self.rejected.clear();
            self.histogram.outliers(&mut self.rejected);
            for &i in &self.rejected {
                if matches[i].take().is_some() {
                    found -= 1;
                }
            }
        }
        found
    }
}

/// The ORB pyramid's scales, as the matcher needs them.
#[derive(Clone, Copy, Debug)]
pub struct ScalePyramid {
    /// Scale between two levels (1.2).
    pub scale_factor: f64,
    /// `ln(scale_factor)`.
    pub log_scale: f64,
    /// Number of levels.
    pub levels: u8,
}

impl ScalePyramid {
    /// The pyramid of `levels` levels `scale_factor` apart.
    pub fn new(scale_factor: f64, levels: u8) -> Self {
        Self {
            scale_factor,
            log_scale: scale_factor.ln(),
            levels,
        }
    }

    /// Scale of `level` relative to level 0.
    pub fn factor(&self, level: u8) -> f64 {
        self.scale_factor.powi(i32::from(level))
    }

    /// Inverse variance of a keypoint position at `level` (sigma = scale^level px).
    pub fn inv_sigma2(&self, level: u32) -> f64 {
        self.scale_factor.powi(-2 * level as i32)
    }
}
