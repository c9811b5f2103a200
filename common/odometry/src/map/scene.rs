//! The map as a viewer draws it ([`gfs_core::scene::Scene`]): points, lines with their
//! Manhattan axis, planes bounded to what was seen of them, keyframe poses.

use super::Map;
use gfs_core::scene::{Scene, SceneLine, ScenePlane};
use nalgebra::{Point3, Vector3};

/// Map points within this distance of a plane count towards its patch, metres.
const ON_PLANE_M: f64 = 0.03;
/// ... and within this distance of where its keyframes saw it, metres.
const NEAR_PLANE_M: f64 = 2.0;
/// Points a patch needs to take its extent from them; with fewer it is a square of
/// [`DEFAULT_HALF_SIDE_M`] about where the plane was seen.
const MIN_PATCH_POINTS: usize = 8;
const DEFAULT_HALF_SIDE_M: f64 = 0.25;
/// Fraction of the plane's points left out at each side of a patch (stray points).
const PATCH_TRIM: f64 = 0.05;
/// Largest angle between a plane normal and a Manhattan axis for it to take the axis.
const PLANE_AXIS_MAX_DEG: f64 = 10.0;

impl Map {
    /// The map as a viewer draws it. The Manhattan axes are the mean directions of the
    /// lines assigned to each (none before a line has each axis).
    pub fn scene(&self) -> Scene {
        let keyframes = self
            .keyframe_ids()
            .iter()
            .filter_map(|id| self.keyframes.get(id))
            .map(|kf| kf.world_from_camera())
            .collect();
        let points: Vec<Point3<f64>> = self.points.items.values().map(|p| p.position).collect();
        let lines: Vec<SceneLine> = self
            .lines
            .items
            .values()
            .map(|l| SceneLine {
                ends: [l.start, l.end],
                axis: l.axis,
            })
            .collect();
        let axes = manhattan_axes(&lines);
        let planes = self
            .planes
            .items
            .values()
            .filter_map(|plane| {
                let seen = self.seen_centre(&plane.observations)?;
                let centre = seen - (plane.normal.dot(&seen.coords) + plane.offset) * plane.normal;
                let in_plane = in_plane_basis(&plane.normal, axes.as_ref());
                Some(ScenePlane {
                    corners: patch_corners(&points, &plane.normal, plane.offset, centre, in_plane),
                    normal: plane.normal,
                    axis: axes.as_ref().and_then(|a| axis_of(&plane.normal, a)),
                })
            })
            .collect();
        Scene {
            points,
            lines,
            planes,
            keyframes,
            axes,
        }
    }

    /// The mean of the plane centroids its observing keyframes measured, world frame.
    fn seen_centre(
        &self,
        observations: &[(gfs_core::ids::KeyFrameId, u32)],
    ) -> Option<Point3<f64>> {
        let mut sum = Vector3::zeros();
        let mut n = 0.0;
        for (kf, index) in observations {
            let Some(keyframe) = self.keyframes.get(kf) else {
                continue;
            };
            let Some(seen) = keyframe.features.planes.get(*index as usize) else {
                continue;
            };
            let centroid = Point3::from(Vector3::from(seen.centroid.map(f64::from)));
            sum += (keyframe.world_from_camera() * centroid).coords;
            n += 1.0;
        }
        (n > 0.0).then(|| Point3::from(sum / n))
    }
}

/// The mean direction of the lines of each axis, signs aligned to the first line's;
/// `None` unless all three axes have a line.
fn manhattan_axes(lines: &[SceneLine]) -> Option<[Vector3<f64>; 3]> {
    let mut sums = [Vector3::zeros(); 3];
    for line in lines {
        let Some(k) = line.axis.filter(|k| *k < 3) else {
            continue;
        };
        let Some(d) = (line.ends[1] - line.ends[0]).try_normalize(1e-9) else {
            continue;
        };
        let sum = &mut sums[k as usize];
        *sum += if sum.dot(&d) < 0.0 { -d } else { d };
    }
    let [a, b, c] = sums.map(|s| s.try_normalize(1e-9));
    Some([a?, b?, c?])
}

/// The axis within [`PLANE_AXIS_MAX_DEG`] of `normal`.
fn axis_of(normal: &Vector3<f64>, axes: &[Vector3<f64>; 3]) -> Option<u8> {
    let min_cos = PLANE_AXIS_MAX_DEG.to_radians().cos();
    (0u8..3).find(|&k| normal.dot(&axes[k as usize]).abs() >= min_cos)
}

/// Two unit vectors spanning the plane of `normal`: along the Manhattan axis most
/// perpendicular to it when the axes are known (walls drawn as upright rectangles).
fn in_plane_basis(normal: &Vector3<f64>, axes: Option<&[Vector3<f64>; 3]>) -> [Vector3<f64>; 2] {
    let helper = axes
        .and_then(|a| {
            a.iter()
                .min_by(|x, y| x.dot(normal).abs().total_cmp(&y.dot(normal).abs()))
                .copied()
        })
        .unwrap_or_else(|| {
            if normal.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            }
        });
    let u = (helper - helper.dot(normal) * normal)
        .try_normalize(1e-9)
        .unwrap_or_else(|| normal.cross(&Vector3::z()).normalize());
    [u, normal.cross(&u)]
}

/// The rectangle in the plane (`normal`, `offset`) holding the map points on it near
/// `centre`, trimmed by [`PATCH_TRIM`] each side; a square about `centre` without
/// enough points.
fn patch_corners(
    points: &[Point3<f64>],
    normal: &Vector3<f64>,
    offset: f64,
    centre: Point3<f64>,
    [u, v]: [Vector3<f64>; 2],
) -> [Point3<f64>; 4] {
    let (mut us, mut vs) = (Vec::new(), Vec::new());
    for p in points {
        let d = p - centre;
        if (normal.dot(&p.coords) + offset).abs() <= ON_PLANE_M && d.norm() <= NEAR_PLANE_M {
            us.push(d.dot(&u));
            vs.push(d.dot(&v));
        }
    }
    let h = DEFAULT_HALF_SIDE_M;
    let ((u0, u1), (v0, v1)) = if us.len() >= MIN_PATCH_POINTS {
        (trimmed_bounds(&mut us), trimmed_bounds(&mut vs))
    } else {
        ((-h, h), (-h, h))
    };
    [(u0, v0), (u1, v0), (u1, v1), (u0, v1)].map(|(a, b)| centre + a * u + b * v)
}

/// The [`PATCH_TRIM`] and `1 - PATCH_TRIM` quantiles of `values` (not empty).
fn trimmed_bounds(values: &mut [f64]) -> (f64, f64) {
    values.sort_unstable_by(f64::total_cmp);
    let last = values.len() - 1;
    let at = |q: f64| values[((q * last as f64).round() as usize).min(last)];
    (at(PATCH_TRIM), at(1.0 - PATCH_TRIM))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_patch_spans_the_points_on_its_plane() {
        // The floor y = 1 (normal -y, offset 1): points on a 2 m x 1 m grid, one stray
        // point off the plane and one too far.
        let mut points: Vec<Point3<f64>> = (0..21)
            .flat_map(|i| {
                (0..11).map(move |j| Point3::new(f64::from(i) * 0.1, 1.0, f64::from(j) * 0.1))
            })
            .collect();
        points.push(Point3::new(0.5, 0.5, 0.5));
        points.push(Point3::new(9.0, 1.0, 9.0));
        let normal = -Vector3::y();
        let centre = Point3::new(1.0, 1.0, 0.5);
        let basis = in_plane_basis(&normal, None);
        let corners = patch_corners(&points, &normal, 1.0, centre, basis);
        for c in &corners {
            assert!((c.y - 1.0).abs() < 1e-9, "{c}");
        }
        let xs = corners.map(|c| c.x);
        let zs = corners.map(|c| c.z);
        let span = |v: [f64; 4]| {
            v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
        };
        // 5 % trimmed each side of 0..2 m and 0..1 m.
        assert!((span(xs) - 1.8).abs() < 0.11, "{xs:?}");
        assert!((span(zs) - 0.9).abs() < 0.11, "{zs:?}");
        // Without points: a 0.5 m square about the centre.
        let corners = patch_corners(&[], &normal, 1.0, centre, basis);
        assert!((span(corners.map(|c| c.x)) - 0.5).abs() < 1e-9);
    }

    #[test]
    fn the_axes_are_the_mean_line_directions_and_planes_take_the_nearest() {
        let line = |a: [f64; 3], b: [f64; 3], axis| SceneLine {
            ends: [Point3::from(a), Point3::from(b)],
            axis: Some(axis),
        };
        let lines = [
            line([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0),
            line([1.0, 1.0, 0.0], [0.0, 1.0, 0.01], 0),
            line([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 1),
        ];
        assert_eq!(manhattan_axes(&lines), None);
        let mut all = lines.to_vec();
        all.push(line([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 2));
        let axes = manhattan_axes(&all).unwrap();
        assert!(axes[0].x > 0.999 && axes[0].z.abs() < 0.01, "{}", axes[0]);
        assert_eq!(
            axis_of(&Vector3::new(0.05, 0.0, -1.0).normalize(), &axes),
            Some(2)
        );
        assert_eq!(
            axis_of(&Vector3::new(1.0, 1.0, 0.0).normalize(), &axes),
            None
        );
    }
}
