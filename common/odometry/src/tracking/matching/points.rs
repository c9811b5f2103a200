//! Point matching by projection (ORB-SLAM2's `SearchByProjection`): a map point is
//! projected with the predicted pose and compared only with the keypoints of the grid
//! cells within a scale-dependent radius, at the pyramid levels its distance predicts.

use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::MapPointId;
use gfs_points::{KeyPointGrid, RotationHistogram, best_two};
use nalgebra::{Isometry3, Point3};
use serde::Deserialize;

/// Keypoint grid cell, pixels (ORB-SLAM2 uses a 64x48 grid on 640x480: 10 px).
const POINT_GRID_CELL_PX: f32 = 10.0;

/// `[tracking.points]`: thresholds of point matching by projection.
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
/// A map point is looked for only within this range of the distances its descriptor
/// was seen at (ORB-SLAM2 `isInFrustum`: 0.8 x min to 1.2 x max).
const SCALE_RANGE_MARGIN: (f64, f64) = (0.8, 1.2);
/// A map point seen from more than 60 degrees off its mean viewing direction has
/// changed appearance too much to match (ORB-SLAM2 `isInFrustum`: cos 60 = 0.5).
const MIN_VIEW_COS: f64 = 0.5;

/// How far around its projection a map point is looked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointWindow {
    /// A fixed radius, pixels at level 0 (scaled by the predicted level's scale).
    Radius(f64),
    /// ORB-SLAM2's `RadiusByViewingCos` times this factor: 2.5 px at level 0 for a
    /// point seen close to its mean viewing direction, 4 px otherwise.
    ByViewingAngle(f64),
}

/// A map point to look for, with the keypoint angle it was seen at (for the
/// orientation check), if known.
#[derive(Clone, Copy, Debug)]
pub struct ProjectionCandidate {
    /// The map point.
    pub id: MapPointId,
    /// Orientation of the keypoint that last observed it, radians.
    pub angle: Option<f32>,
}

/// Matches map points to the keypoints of the current frame by projection; owns the
/// frame's keypoint grid and the buffers of the search.
#[derive(Debug)]
pub struct PointProjectionMatcher {
    config: PointMatchConfig,
    camera: PinholeCamera,
    scale: ScalePyramid,
    grid: KeyPointGrid,
    nearby: Vec<usize>,
    best: Vec<u32>,
    histogram: RotationHistogram,
    rejected: Vec<usize>,
    in_view: Vec<MapPointId>,
}

impl PointProjectionMatcher {
    /// A matcher for `camera` whose keypoints come from the pyramid `scale`.
    pub fn new(config: PointMatchConfig, camera: PinholeCamera, scale: ScalePyramid) -> Self {
        Self {
            grid: KeyPointGrid::new(camera.width, camera.height, POINT_GRID_CELL_PX),
            nearby: Vec::new(),
            best: Vec::new(),
            histogram: RotationHistogram::default(),
            rejected: Vec::new(),
            in_view: Vec::new(),
            config,
            camera,
            scale,
        }
    }

    /// The pyramid of the keypoints.
    pub fn scale(&self) -> &ScalePyramid {
        &self.scale
    }

    /// Indexes the keypoints of the frame the next searches look in.
    pub fn index(&mut self, frame: &FrameFeatures) {
        self.grid.build(&frame.keypoints);
    }

    /// The candidates of the last search that projected into the view (in front of the
    /// camera, inside the image, within their scale range and viewing angle).
    pub fn in_view(&self) -> &[MapPointId] {
        &self.in_view
    }

    /// Projects each candidate with `camera_from_world` and links it to the closest
    /// free keypoint of the indexed frame within `window`. `matches[i]` is set for
    /// keypoint `i`; already set entries are kept. Returns the number of new matches.
    pub fn search(
        &mut self,
        map: &Map,
        candidates: &[ProjectionCandidate],
        camera_from_world: &Isometry3<f64>,
        frame: &FrameFeatures,
        window: PointWindow,
        matches: &mut [Option<MapPointId>],
    ) -> usize {
        let n = frame.keypoints.len().min(matches.len());
        self.best.clear();
        self.best.resize(n, u32::MAX);
        self.histogram.clear();
        self.in_view.clear();
        let world_from_camera = camera_from_world.inverse();
        let centre = Point3::from(world_from_camera.translation.vector);
        let mut found = 0;
        for candidate in candidates {
            let Some(point) = map.point(candidate.id) else {
                continue;
            };
            let p_c = camera_from_world * point.position;
            let Some(uv) = self.camera.project(&p_c) else {
                continue;
            };
            if !self.camera.contains(uv.x, uv.y, 0.0) {
                continue;
            }
            let to_point = point.position - centre;
            let distance = to_point.norm();
            let (near, far) = SCALE_RANGE_MARGIN;
            if distance < near * point.min_distance || distance > far * point.max_distance {
                continue;
            }
            if to_point.dot(&point.normal) > -MIN_VIEW_COS * distance {
                continue;
            }
            self.in_view.push(candidate.id);
            let level = point.predict_level(distance, self.scale.log_scale, self.scale.levels);
            let radius = match window {
                PointWindow::Radius(radius) => radius,
                PointWindow::ByViewingAngle(factor) => {
                    if -to_point.dot(&point.normal) > CLOSE_VIEW_COS * distance {
                        factor * CLOSE_VIEW_RADIUS_PX
                    } else {
                        factor * WIDE_VIEW_RADIUS_PX
                    }
                }
            };
            let level_radius = radius * self.scale.factor(level);
            let (min_level, max_level) = (level.saturating_sub(1), level + 1);
            self.grid.features_in_area(
                uv.x as f32,
                uv.y as f32,
                level_radius as f32,
                u32::from(min_level),
                u32::from(max_level),
                &mut self.nearby,
            );
            let free = self
                .nearby
                .iter()
                .filter(|&&i| i < n && matches[i].is_none())
                .map(|&i| (i, &frame.point_descriptors[i]));
            let Some(best) = best_two(&point.descriptor, free) else {
                continue;
            };
            let i = best.index;
            if best.distance > self.config.max_distance || best.distance >= self.best[i] {
                continue;
            }
            // Two candidates at different levels are different structures, not an
            // ambiguity (ORB-SLAM2 `SearchByProjection`).
            let same_level = best.second_index != usize::MAX
                && frame.keypoints[best.second_index].level == frame.keypoints[i].level;
            if same_level && !best.passes_ratio_or_ties(self.config.ratio) {
                continue;
            }
            self.best[i] = best.distance;
            if matches[i].is_none() {
                found += 1;
            }
            matches[i] = Some(candidate.id);
            if let Some(angle) = candidate.angle {
                self.histogram.add(angle, frame.keypoints[i].angle, i);
            }
        }
        if self.config.check_orientation {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, camera, first_keyframe, pose, scale};

    fn setup() -> (Map, Vec<ProjectionCandidate>, Scene) {
        let scene = Scene::new(200, 0);
        let (map, _, _) = first_keyframe(&scene, &OdometryConfig::default());
        let mut ids: Vec<MapPointId> = map.point_ids().collect();
        ids.sort_unstable();
        let candidates = ids
            .into_iter()
            .map(|id| ProjectionCandidate { id, angle: None })
            .collect();
        (map, candidates, scene)
    }

    #[test]
    fn map_points_match_their_keypoints_from_the_true_pose() {
        let (map, candidates, scene) = setup();
        let at = pose(0.03, 0.01);
        let frame = scene.features(1, &at);
        let mut matcher =
            PointProjectionMatcher::new(PointMatchConfig::default(), camera(), scale());
        matcher.index(&frame);
        let mut matches = vec![None; frame.keypoints.len()];
        let found = matcher.search(
            &map,
            &candidates,
            &at,
            &frame,
            PointWindow::Radius(15.0),
            &mut matches,
        );
        let in_image = frame.keypoints.iter().filter(|k| k.depth > 0.0).count();
        assert_eq!((found, matcher.in_view().len()), (in_image, in_image));
        // Keypoint i is point i: each match links the keypoint to the point made from it.
        for (i, m) in matches.iter().enumerate() {
            let Some(id) = m else { continue };
            let p = map.point(*id).expect("point");
            assert_eq!(p.descriptor, frame.point_descriptors[i]);
        }
        // Entries already set are kept: a second search adds nothing.
        let again = matcher.search(
            &map,
            &candidates,
            &at,
            &frame,
            PointWindow::Radius(15.0),
            &mut matches,
        );
        assert_eq!(again, 0);
    }

    #[test]
    fn the_window_decides_how_far_off_a_prediction_may_be() {
        let (map, candidates, scene) = setup();
        let at = pose(0.0, 0.0);
        let frame = scene.features(1, &at);
        // Predicted 2 degrees off: about 18 px at 525 px focal length.
        let predicted = pose(0.0, 2f64.to_radians());
        let mut matcher =
            PointProjectionMatcher::new(PointMatchConfig::default(), camera(), scale());
        matcher.index(&frame);
        let mut run = |window| {
            let mut matches = vec![None; frame.keypoints.len()];
            matcher.search(&map, &candidates, &predicted, &frame, window, &mut matches)
        };
        let narrow = run(PointWindow::Radius(10.0));
        let wide = run(PointWindow::Radius(50.0));
        // ByViewingAngle(3): 3 x 2.5 px for a point seen along its mean view.
        let local_map = run(PointWindow::ByViewingAngle(3.0));
        assert!(narrow < 20 && local_map < 20, "{narrow} {local_map}");
        assert!(wide > 150, "{wide}");
    }

    #[test]
    fn scale_factors_and_sigmas_follow_the_level() {
        let s = scale();
        assert!((s.factor(2) - 1.44).abs() < 1e-12);
        assert!((s.inv_sigma2(1) - 1.0 / 1.44).abs() < 1e-12);
        assert!((s.log_scale - 1.2f64.ln()).abs() < 1e-15);
    }
}
