//! A keypoint's depth: the pixel under it, and at an occlusion edge the depth of the
//! surface whose outline makes the corner, or none when no surface does.

use gfs_core::ImageView;

/// A pixel's 3x3 neighbours, nearest first (tried in turn when its depth is missing).
const NEIGHBOURS: [(isize, isize); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (-1, 1),
    (1, -1),
    (-1, -1),
];

/// Depths within this fraction of the nearer one are on one surface; beyond, an
/// occlusion edge: well above the sensor's noise across a few pixels of one surface
/// (Kinect: about 0.3 % of the depth per pixel at 1-3 m, plus an oblique surface's slope).
const EDGE_DEPTH_SPAN: f32 = 0.05;

/// An outline within this many pixels of a corner may be the one that draws it: FAST
/// puts a corner's apex a pixel or so off, and the depth's edges are off the colour's
/// by as much again (the sensor's blur and registration).
const OUTLINE_REACH: isize = 2;

/// Radius of the ring of pixels (the border of a 7x7 window, just outside the outline's
/// reach) on which the share of the nearer surface tells a straight outline from a
/// corner of it.
const RING_RADIUS: isize = 3;
const RING_PIXELS: usize = 8 * RING_RADIUS as usize;

/// A share of the ring on the nearer surface within this range is a straight outline
/// through the keypoint. Of outlines at every angle passing up to 1 px from it, 93 %
/// fall inside; 94 % of the nearer surface's 60-120 degree corners up to 1 px off read
/// its depth (the unit test below).
const STRAIGHT_OUTLINE_SHARE: std::ops::RangeInclusive<f32> = 0.4..=0.6;

/// Fewest valid ring pixels that tell a straight outline from a corner.
const MIN_RING_PIXELS: usize = RING_PIXELS / 3;

/// Depth in metres at the pixel nearest `(u, v)`, else at its nearest valid 3x3
/// neighbour; 0 when none is finite and within `[min_m, max_m]`.
pub fn depth_at(depth: ImageView<'_, f32>, u: f32, v: f32, min_m: f32, max_m: f32) -> f32 {
    if !(u.is_finite() && v.is_finite()) {
        return 0.0;
    }
    let (x, y) = (u.round() as isize, v.round() as isize);
    let valid = |offset| valid_depth(depth, (x, y), offset, min_m, max_m);
    valid((0, 0))
        .or_else(|| NEIGHBOURS.iter().find_map(|&offset| valid(offset)))
        .unwrap_or(0.0)
}

/// The depth of the 3D point a corner at `(u, v)` is, in metres; 0 for none.
///
/// Off an occlusion edge it is [`depth_at`]. Where an outline between two surfaces
/// passes within 2 pixels of the corner (its 5x5 pixels span both), the
/// pixel under the corner may read either surface, but the outline belongs to the
/// nearer one:
/// - a corner of that outline (the nearer surface covering a quarter of the ring around
///   the keypoint, say a table's corner against the wall, or three quarters) is a point
///   of the nearer surface: its depth;
/// - a straight outline (half the ring) makes a corner only where it crosses a line on
///   the surface behind: a T-junction, no point in space, sliding along the outline as
///   the camera moves. It gets no depth, as over a hole, and is used as a bearing.
///
/// Read at the wall's depth, a table's corners pulled the pose along the wall by
/// several millimetres a frame on fast motion past a table in a bare room.
pub fn keypoint_depth(depth: ImageView<'_, f32>, u: f32, v: f32, min_m: f32, max_m: f32) -> f32 {
    let under = depth_at(depth, u, v, min_m, max_m);
    if under == 0.0 {
        return 0.0;
    }
    let (x, y) = (u.round() as isize, v.round() as isize);
    let (mut nearer, mut farther) = (under, under);
    let columns = reach(x, depth.width());
    for row in reach(y, depth.height()) {
        for &z in &depth.row(row)[columns.clone()] {
            if in_range(z, min_m, max_m) {
                nearer = nearer.min(z);
                farther = farther.max(z);
            }
        }
    }
    let on_nearer = |z: f32| z <= nearer * (1.0 + EDGE_DEPTH_SPAN);
    if on_nearer(farther) {
        return under;
    }
    let (mut ring, mut ring_on_nearer) = (0, 0);
    for (dx, dy) in ring_offsets() {
        if let Some(z) = valid_depth(depth, (x, y), (dx, dy), min_m, max_m) {
            ring += 1;
            ring_on_nearer += usize::from(on_nearer(z));
        }
    }
    let straight = ring >= MIN_RING_PIXELS
        && STRAIGHT_OUTLINE_SHARE.contains(&(ring_on_nearer as f32 / ring as f32));
    if straight { 0.0 } else { nearer }
}

/// The pixels within the outline's reach of `centre` along an axis of `len` pixels.
fn reach(centre: isize, len: usize) -> std::ops::Range<usize> {
    let len = len as isize;
    let start = centre.saturating_sub(OUTLINE_REACH).clamp(0, len);
    let end = centre.saturating_add(OUTLINE_REACH + 1).clamp(start, len);
    start as usize..end as usize
}

/// The offsets of the ring's pixels, clockwise from its top-left corner.
fn ring_offsets() -> impl Iterator<Item = (isize, isize)> {
    let r = RING_RADIUS;
    (-r..r)
        .map(move |i| (i, -r))
        .chain((-r..r).map(move |i| (r, i)))
        .chain((-r..r).map(move |i| (-i, r)))
        .chain((-r..r).map(move |i| (-r, -i)))
}

/// The depth at the pixel `offset` from `centre` if it is inside the image, finite and
/// within `[min_m, max_m]` (and positive).
fn valid_depth(
    depth: ImageView<'_, f32>,
    (x, y): (isize, isize),
    (dx, dy): (isize, isize),
    min_m: f32,
    max_m: f32,
) -> Option<f32> {
    let (x, y) = (x.saturating_add(dx), y.saturating_add(dy));
    if x < 0 || y < 0 {
        return None;
    }
    depth
        .get(x as usize, y as usize)
        .filter(|&z| in_range(z, min_m, max_m))
}

/// A depth is valid when it is finite, positive and within `[min_m, max_m]`.
fn in_range(z: f32, min_m: f32, max_m: f32) -> bool {
    z.is_finite() && z >= min_m && z <= max_m && z > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::Image;

    const TABLE_M: f32 = 1.0;
    const WALL_M: f32 = 2.0;

    /// A 24x24 depth image: the wall, and a table in front of it where `on_table` says,
    /// both with 0.2 % of ripple (above the sensor's quantisation, below the edge span).
    fn scene(on_table: impl Fn(usize, usize) -> bool) -> Image<f32> {
        let data = (0..24 * 24)
            .map(|i| {
                let (x, y) = (i % 24, i / 24);
                let ripple = 1.0 + 0.002 * ((x * 7 + y * 3) % 5) as f32 / 4.0;
                ripple * if on_table(x, y) { TABLE_M } else { WALL_M }
            })
            .collect();
        Image::from_vec(24, 24, data).unwrap()
    }

    fn at(depth: &Image<f32>, u: f32, v: f32) -> f32 {
        keypoint_depth(depth.view(), u, v, 0.1, 10.0)
    }

    #[test]
    fn a_corner_of_the_nearer_surface_takes_its_depth_where_the_pixel_under_it_reads_the_wall() {
        let square = scene(|x, y| x <= 10 && y <= 10);
        let wall = depth_at(square.view(), 11.4, 11.3, 0.1, 10.0);
        assert!(
            (wall - WALL_M).abs() < 0.01,
            "the pixel under reads the wall: {wall}"
        );
        for (u, v) in [(11.4, 11.3), (10.0, 10.0), (11.0, 10.0), (10.0, 11.0)] {
            let z = at(&square, u, v);
            assert!((z - TABLE_M).abs() < 0.01, "({u}, {v}): {z} m");
        }
        // A corner of the wall showing past the table (the table covers three quarters).
        let notch = scene(|x, y| x <= 10 || y <= 10);
        let z = at(&notch, 11.0, 11.0);
        assert!((z - TABLE_M).abs() < 0.01, "{z} m");
    }

    #[test]
    fn a_corner_on_a_straight_outline_is_a_t_junction_and_gets_no_depth() {
        // Keypoints on either side of the outline, next to it.
        let outlines = [
            (
                "vertical",
                scene(|x, _| x <= 10),
                [(10.0, 11.0), (11.0, 11.0), (11.0, 13.0)],
            ),
            (
                "horizontal",
                scene(|_, y| y >= 12),
                [(10.0, 11.0), (11.0, 12.0), (13.0, 12.0)],
            ),
            (
                "oblique",
                scene(|x, y| 2 * x + y <= 32),
                [(11.0, 10.0), (11.0, 11.0), (10.0, 13.0)],
            ),
        ];
        for (name, table, keypoints) in outlines {
            for (u, v) in keypoints {
                assert_eq!(at(&table, u, v), 0.0, "{name} outline at ({u}, {v})");
            }
        }
    }

    #[test]
    fn off_the_outline_a_keypoint_keeps_the_depth_under_it() {
        let table = scene(|x, _| x <= 10);
        assert!((at(&table, 13.0, 11.0) - WALL_M).abs() < 0.01);
        assert!((at(&table, 8.0, 11.0) - TABLE_M).abs() < 0.01);
        let flat = scene(|_, _| false);
        assert_eq!(at(&flat, 11.0, 11.0), flat.view().get(11, 11).unwrap());
    }

    #[test]
    fn holes_and_the_image_border_are_read_without_a_panic() {
        let mut table = scene(|x, y| x <= 10 && y <= 10);
        for (x, y) in [(11, 11), (12, 11), (11, 12)] {
            table.set(x, y, f32::NAN);
        }
        // The centre is a hole: its nearest valid neighbour, then the outline's rule.
        assert!((at(&table, 11.0, 11.0) - TABLE_M).abs() < 0.01);
        // Holes all round: nothing to read.
        let holes = Image::from_vec(24, 24, vec![0.0f32; 24 * 24]).unwrap();
        assert_eq!(at(&holes, 11.0, 11.0), 0.0);
        // Windows cut by the border.
        for (u, v) in [
            (0.0, 0.0),
            (23.0, 23.0),
            (0.0, 11.0),
            (-0.4, 5.0),
            (30.0, 5.0),
        ] {
            let z = at(&table, u, v);
            assert!(z == 0.0 || (0.9..2.1).contains(&z), "({u}, {v}): {z}");
        }
        assert_eq!(at(&table, f32::NAN, 3.0), 0.0);
        for (u, v) in [(1e30, 5.0), (-1e30, 5.0), (5.0, 1e30), (f32::INFINITY, 5.0)] {
            assert_eq!(at(&table, u, v), 0.0, "({u}, {v})");
        }
    }

    /// Depth where the nearer surface is the half-plane `n . (p - c) <= offset` (a
    /// straight outline) or, with `wedge_deg`, the wedge of that opening around `n`
    /// with its apex `offset` px from the keypoint along `n` (a corner of it).
    fn outline(angle_deg: f32, offset: f32, wedge_deg: Option<f32>) -> Image<f32> {
        let (s, c) = angle_deg.to_radians().sin_cos();
        scene(|x, y| {
            let (dx, dy) = (x as f32 - 11.0, y as f32 - 11.0);
            match wedge_deg {
                None => c * dx + s * dy <= offset,
                Some(opening) => {
                    let (ax, ay) = (dx - c * offset, dy - s * offset);
                    let off_axis = (ay * c - ax * s).atan2(ax * c + ay * s).abs();
                    (ax == 0.0 && ay == 0.0) || off_axis <= (opening / 2.0).to_radians()
                }
            }
        })
    }

    #[test]
    fn straight_outlines_at_every_angle_read_as_bearings_and_corners_as_the_nearer_surface() {
        let mut straight = (0, 0);
        for angle in (0..180).step_by(5) {
            for offset in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                straight.0 +=
                    usize::from(at(&outline(angle as f32, offset, None), 11.0, 11.0) == 0.0);
                straight.1 += 1;
            }
        }
        let mut corners = (0, 0);
        for angle in (0..360).step_by(15) {
            for offset in [-1.0, 0.0, 1.0] {
                for opening in [60.0, 90.0, 120.0] {
                    let z = at(&outline(angle as f32, offset, Some(opening)), 11.0, 11.0);
                    corners.0 += usize::from((z - TABLE_M).abs() < 0.01);
                    corners.1 += 1;
                }
            }
        }
        let share = |(hits, all): (usize, usize)| hits as f64 / all as f64;
        assert!(
            share(straight) >= 0.9,
            "straight outlines read as bearings: {straight:?}"
        );
        assert!(
            share(corners) >= 0.9,
            "corners read at the nearer surface: {corners:?}"
        );
    }
}
