//! Grid-based line matching (paper section III-C, "Grid-based Tracking"): a map line is
//! projected with the predicted pose, and only the lines of the current frame in the
//! grid cells it traverses (and their neighbours) are compared with its LBD
//! descriptor. When too few lines match, the "extension search" (paper Fig. 6) also
//! looks along the cells of the projected line's infinite extension, since a broken
//! line keeps its slope.

use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::MapLineId;
use gfs_lines::Segment;
use gfs_lines::grid::{CellId, GridConfig, LineGrid};
use gfs_points::best_two;
use nalgebra::{Isometry3, Point3};
use serde::Deserialize;

/// `[tracking.lines]`: thresholds of grid-based line matching.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineMatchConfig {
    /// Largest LBD Hamming distance of a match (of 256 bits). Default 80.
    pub max_distance: u32,
    /// Best / second-best distance ratio. Default 0.85.
    pub ratio: f32,
    /// Largest angle between the projected map line and a candidate, degrees. Default 8.
    pub max_angle_deg: f32,
    /// Largest distance from the candidate's midpoint to the projected infinite line,
    /// pixels. Default 20.
    pub max_offset_px: f32,
    /// Neighbourhood of the traversed cells searched, in cells. Default 1 (3x3).
    pub cell_radius: usize,
}

impl Default for LineMatchConfig {
    fn default() -> Self {
        Self {
            max_distance: 80,
            ratio: 0.85,
            max_angle_deg: 8.0,
            max_offset_px: 20.0,
            cell_radius: 1,
        }
    }
}

/// Closest a projected endpoint may be to the camera plane, metres.
const MIN_ENDPOINT_DEPTH: f64 = 0.05;

/// Which grid cells a projected map line looks in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineWindow {
    /// The cells the projected segment traverses, and their neighbours.
    Segment,
    /// Those and the cells along the projected line's infinite extension (paper Fig. 6).
    Extension,
}

/// Matches map lines to the lines of the current frame through the frame's line grid;
/// owns the grid and the buffers of the search.
#[derive(Debug)]
pub struct LineProjectionMatcher {
    config: LineMatchConfig,
    camera: PinholeCamera,
    grid: LineGrid,
    cells: Vec<CellId>,
    candidates: Vec<u32>,
    best: Vec<u32>,
    in_view: Vec<MapLineId>,
}

impl LineProjectionMatcher {
    /// A matcher for `camera` whose frame lines are indexed on the grid `grid` (the
    /// line front end's).
    pub fn new(config: LineMatchConfig, camera: PinholeCamera, grid: &GridConfig) -> Self {
        Self {
            grid: LineGrid::new(grid),
            cells: Vec::new(),
            candidates: Vec::new(),
            best: Vec::new(),
            in_view: Vec::new(),
            config,
            camera,
        }
    }

    /// Indexes the lines of the frame the next searches look in.
    pub fn index(&mut self, frame: &FrameFeatures) {
        self.grid.build(
            self.camera.width,
            self.camera.height,
            frame.lines.iter().map(|l| &l.segment),
        );
    }

    /// The map lines of the last search that projected into the view.
    pub fn in_view(&self) -> &[MapLineId] {
        &self.in_view
    }

    /// Projects each map line with `camera_from_world` and links it to the best free
    /// line of the indexed frame among the grid cells of `window`. `matches[j]` is set
    /// for frame line `j`; set entries are kept. Returns the number of new matches.
    pub fn search(
        &mut self,
        map: &Map,
        lines: &[MapLineId],
        camera_from_world: &Isometry3<f64>,
        frame: &FrameFeatures,
        window: LineWindow,
        matches: &mut [Option<MapLineId>],
    ) -> usize {
        let n = frame.lines.len().min(matches.len());
        self.best.clear();
        self.best.resize(n, u32::MAX);
        self.in_view.clear();
        let max_angle = self.config.max_angle_deg.to_radians();
        let mut found = 0;
        for &id in lines {
            let Some(line) = map.line(id) else {
                continue;
            };
            let Some(projected) =
                project_segment(&self.camera, camera_from_world, &line.start, &line.end)
            else {
                continue;
            };
            self.in_view.push(id);
            self.grid.candidates(
                &projected,
                self.config.cell_radius,
                window == LineWindow::Extension,
                &mut self.cells,
                &mut self.candidates,
            );
            let [a, b, c] = projected.line_coefficients();
            let max_offset = self.config.max_offset_px;
            let free = self
                .candidates
                .iter()
                .map(|&j| j as usize)
                .filter(|&j| j < n && matches[j].is_none())
                .filter(|&j| {
                    let observed = &frame.lines[j].segment;
                    let [mu, mv] = observed.midpoint();
                    let off = undirected_angle(observed.angle(), projected.angle()) > max_angle
                        || (a * mu + b * mv + c).abs() > max_offset;
                    !off
                })
                .map(|j| (j, &frame.line_descriptors[j]));
            let Some(best) = best_two(&line.descriptor, free) else {
                continue;
            };
            let j = best.index;
            if best.distance > self.config.max_distance
                || best.distance >= self.best[j]
                || !best.passes_ratio_or_ties(self.config.ratio)
            {
                continue;
            }
            self.best[j] = best.distance;
            if matches[j].is_none() {
                found += 1;
            }
            matches[j] = Some(id);
        }
        found
    }
}

/// Projects a world segment, clipping it where it passes behind the camera; `None` when
/// it is entirely behind or degenerate. The projection may extend beyond the image: the
/// grid clips it.
pub fn project_segment(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    start: &Point3<f64>,
    end: &Point3<f64>,
) -> Option<Segment> {
    let (mut s, mut e) = (camera_from_world * start, camera_from_world * end);
    if s.z < MIN_ENDPOINT_DEPTH && e.z < MIN_ENDPOINT_DEPTH {
        return None;
    }
    // Move the endpoint behind the camera along the segment to the minimum depth.
    if s.z < MIN_ENDPOINT_DEPTH {
        let t = (MIN_ENDPOINT_DEPTH - s.z) / (e.z - s.z);
        s += (e - s) * t;
    } else if e.z < MIN_ENDPOINT_DEPTH {
        let t = (MIN_ENDPOINT_DEPTH - e.z) / (s.z - e.z);
        e += (s - e) * t;
    }
    let (a, b) = (camera.project(&s)?, camera.project(&e)?);
    let segment = Segment::new(a.x as f32, a.y as f32, b.x as f32, b.y as f32);
    let visible = camera.contains(a.x, a.y, 0.0) || camera.contains(b.x, b.y, 0.0);
    (segment.length() > 1.0 && visible).then_some(segment)
}

/// Angle between two undirected line directions, in [0, pi/2].
fn undirected_angle(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(std::f32::consts::PI);
    d.min(std::f32::consts::PI - d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undirected_angles_ignore_direction() {
        use std::f32::consts::PI;
        assert!(undirected_angle(0.1, 0.1 + PI) < 1e-6);
        assert!((undirected_angle(0.0, PI / 2.0) - PI / 2.0).abs() < 1e-6);
        assert!((undirected_angle(0.05, -0.05) - 0.1).abs() < 1e-6);
    }

    #[test]
    fn a_segment_crossing_the_camera_plane_is_clipped() {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        let s = project_segment(
            &camera,
            &Isometry3::identity(),
            &Point3::new(0.0, 0.0, 2.0),
            &Point3::new(0.0, 0.5, -1.0),
        )
        .unwrap();
        assert_eq!(s.start, [320.0, 240.0]);
        assert!(
            s.end[1] > 480.0,
            "clipped endpoint projects far below: {:?}",
            s.end
        );
        assert!(
            project_segment(
                &camera,
                &Isometry3::identity(),
                &Point3::new(0.0, 0.0, -1.0),
                &Point3::new(1.0, 0.0, -2.0)
            )
            .is_none()
        );
    }
}

#[cfg(test)]
mod search_tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, camera, first_keyframe, pose};

    #[test]
    fn map_lines_match_their_segments_and_the_extension_reaches_shifted_ones() {
        let scene = Scene::new(120, 12);
        let (map, _, _) = first_keyframe(&scene, &OdometryConfig::default());
        let mut ids: Vec<MapLineId> = map.line_ids().collect();
        ids.sort_unstable();
        let at = pose(0.02, 0.0);
        let frame = scene.features(1, &at);
        let mut matcher = LineProjectionMatcher::new(
            LineMatchConfig::default(),
            camera(),
            &GridConfig::default(),
        );
        matcher.index(&frame);
        let mut matches = vec![None; frame.lines.len()];
        let found = matcher.search(&map, &ids, &at, &frame, LineWindow::Segment, &mut matches);
        assert_eq!((found, matcher.in_view().len()), (12, 12));
        for (j, m) in matches.iter().enumerate() {
            let line = map.line(m.expect("every line")).expect("line");
            assert_eq!(line.descriptor, frame.line_descriptors[j]);
        }
        assert_eq!(
            matcher.search(&map, &ids, &at, &frame, LineWindow::Extension, &mut matches),
            0,
            "matched lines stay matched"
        );
    }
}
