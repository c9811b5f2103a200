//! Fixtures of the unit tests: a scene of world points and lines with distinct
//! descriptors, seen by a camera as exact features (no detector, no noise), so that a
//! test can script what every frame sees.

use crate::config::OdometryConfig;
use crate::depth::grid::DepthGrid;
use crate::frontend::features::{Descriptor, FrameFeatures};
use crate::map::manhattan::WorldManhattan;
use crate::map::{KeyFrame, Map};
use crate::mapping::mapper::Mapper;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{FrameId, KeyFrameId};
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;
use gfs_lines::{DetectedLine, Line3, Segment};
use gfs_points::KeyPoint;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// The stamp of frame `k` of a 30 Hz camera.
pub fn frame_stamp(k: u64) -> Stamp {
    Stamp::from_nanos(k as i64 * 1_000_000_000 / 30)
}

/// The camera of the fixtures (TUM-like, 640x480).
pub fn camera() -> PinholeCamera {
    PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
}

/// Three planes `n . x = d` (world frame) meeting in a corner: a floor (y = 1) and two
/// walls (x = 1.2, z = 4), seen from near the origin looking along +z.
pub const CORNER: [([f64; 3], f64); 3] = [
    ([0.0, 1.0, 0.0], 1.0),
    ([1.0, 0.0, 0.0], 1.2),
    ([0.0, 0.0, 1.0], 4.0),
];

/// The exact depth grid (8 px) of the planes `n . x = d` seen from `camera_from_world`,
/// the nearest plane along each node's ray, normals towards the camera.
pub fn planes_depth(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    planes: &[([f64; 3], f64)],
) -> DepthGrid {
    let stride = 8u32;
    let (w, h) = (camera.width as u32 / stride, camera.height as u32 / stride);
    let mut grid = DepthGrid {
        stride_px: stride,
        width: w,
        height: h,
        ..DepthGrid::default()
    };
    let world_from_camera = camera_from_world.inverse();
    let centre = world_from_camera.translation.vector;
    for j in 0..h {
        for i in 0..w {
            let (u, v) = (
                f64::from(i * stride + stride / 2),
                f64::from(j * stride + stride / 2),
            );
            let ray_c = Vector3::new(
                (u - camera.cx) / camera.fx,
                (v - camera.cy) / camera.fy,
                1.0,
            );
            let ray = world_from_camera.rotation * ray_c;
            let hit = planes
                .iter()
                .filter_map(|(n, d)| {
                    let n = Vector3::from(*n);
                    let t = (d - n.dot(&centre)) / n.dot(&ray);
                    (t > 0.0 && t.is_finite()).then_some((t, n))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let (point, normal) = match hit {
                Some((t, n)) => {
                    let p_c = ray_c * t;
                    let mut n_c = camera_from_world.rotation * n;
                    if n_c.dot(&p_c) > 0.0 {
                        n_c = -n_c;
                    }
                    (p_c.cast::<f32>().into(), n_c.cast::<f32>().into())
                }
                None => ([0.0; 3], [0.0; 3]),
            };
            grid.points.push(point);
            grid.normals.push(normal);
        }
    }
    grid
}

/// [`planes_depth`] with the intensity of each node's cell: `texture` of the world point
/// the cell's centre sees, plus the noise of a mean of 64 pixels of 2 gray levels each
/// (`seed`).
pub fn textured_planes_depth(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    planes: &[([f64; 3], f64)],
    texture: impl Fn(&Vector3<f64>) -> f64,
    seed: u64,
) -> DepthGrid {
    let mut grid = planes_depth(camera, camera_from_world, planes);
    let mut rng = SplitMix64::keyed(seed, &[3]);
    let world_from_camera = camera_from_world.inverse();
    let centre = world_from_camera.translation.vector;
    let s = f64::from(grid.stride_px);
    for j in 0..grid.height {
        for i in 0..grid.width {
            let (u, v) = (
                f64::from(i) * s + (s - 1.0) / 2.0,
                f64::from(j) * s + (s - 1.0) / 2.0,
            );
            let ray = world_from_camera.rotation * camera.back_project(u, v, 1.0).coords;
            let t = planes
                .iter()
                .filter_map(|(n, d)| {
                    let n = Vector3::from(*n);
                    let t = (d - n.dot(&centre)) / n.dot(&ray);
                    (t > 0.0 && t.is_finite()).then_some(t)
                })
                .min_by(f64::total_cmp);
            let value = t.map_or(0.0, |t| texture(&(centre + ray * t)));
            let noise = 0.25 * rng.gaussian();
            grid.intensity.push((value + noise) as f32);
        }
    }
    grid.blur_and_coarsen_intensity();
    grid
}

/// The ORB pyramid of the fixtures (8 levels, 1.2 apart).
pub fn scale() -> ScalePyramid {
    ScalePyramid::new(1.2, 8)
}

/// A descriptor of its own for each `(kind, index)`: two differ in about 128 bits.
pub fn descriptor(kind: u64, index: u64) -> Descriptor {
    let mut rng = SplitMix64::keyed(kind, &[index]);
    [
        rng.next_u64(),
        rng.next_u64(),
        rng.next_u64(),
        rng.next_u64(),
    ]
}

/// A camera pose `camera_from_world` after moving `x` metres right and turning `yaw`
/// radians about the vertical.
pub fn pose(x: f64, yaw: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(x, 0.0, 0.0),
        UnitQuaternion::from_euler_angles(0.0, yaw, 0.0),
    )
    .inverse()
}

/// World points and segments in front of the identity camera, 1.5 to 3.5 m away.
pub struct Scene {
    /// Map-point candidates, world.
    pub points: Vec<Point3<f64>>,
    /// Segments, world.
    pub lines: Vec<[Point3<f64>; 2]>,
}

impl Scene {
    /// `points` points on a jittered grid over the image and `lines` segments
    /// (alternately vertical and horizontal), as the identity camera sees them.
    pub fn new(points: usize, lines: usize) -> Self {
        let camera = camera();
        let mut rng = SplitMix64::new(11);
        let cols = (points as f64).sqrt().ceil() as usize;
        let rows = points.div_ceil(cols.max(1));
        let points = (0..points)
            .map(|i| {
                let (c, r) = (i % cols, i / cols);
                let u = 40.0 + (c as f64 + rng.range(0.2, 0.8)) * 560.0 / cols as f64;
                let v = 40.0 + (r as f64 + rng.range(0.2, 0.8)) * 400.0 / rows.max(1) as f64;
                camera.back_project(u, v, rng.range(1.5, 3.5))
            })
            .collect();
        let lines = (0..lines)
            .map(|j| {
                let (u, v) = (60.0 + (j * 47 % 520) as f64, 60.0 + (j * 31 % 300) as f64);
                let depth = 2.0 + 0.1 * (j % 5) as f64;
                let (du, dv) = if j % 2 == 0 { (0.0, 80.0) } else { (90.0, 0.0) };
                [
                    camera.back_project(u, v, depth),
                    camera.back_project(u + du, v + dv, depth),
                ]
            })
            .collect();
        Self { points, lines }
    }

    /// What a camera at `camera_from_world` sees, as frame `id` at `id / 30` s: keypoint
    /// `i` is point `i` (depth measured), line `j` is segment `j` with its 3D line.
    /// Features out of view are kept off-image with no depth, so that indices stay.
    pub fn features(&self, id: u64, camera_from_world: &Isometry3<f64>) -> FrameFeatures {
        let camera = camera();
        let keypoints = self
            .points
            .iter()
            .map(|p| {
                let p_c = camera_from_world * p;
                match camera
                    .project(&p_c)
                    .filter(|uv| camera.contains(uv.x, uv.y, 0.0))
                {
                    Some(uv) => keypoint(uv.x as f32, uv.y as f32, p_c.z as f32),
                    None => keypoint(-100.0, -100.0, 0.0),
                }
            })
            .collect();
        let (mut lines, mut lines3d) = (Vec::new(), Vec::new());
        for [a, b] in &self.lines {
            let (a, b) = (camera_from_world * a, camera_from_world * b);
            let (Some(pa), Some(pb)) = (camera.project(&a), camera.project(&b)) else {
                lines.push(detected(Segment::new(-100.0, -100.0, -90.0, -100.0)));
                lines3d.push(Line3::default());
                continue;
            };
            lines.push(detected(Segment::new(
                pa.x as f32,
                pa.y as f32,
                pb.x as f32,
                pb.y as f32,
            )));
            lines3d.push(Line3 {
                start: [a.x as f32, a.y as f32, a.z as f32],
                end: [b.x as f32, b.y as f32, b.z as f32],
                valid: 1,
            });
        }
        FrameFeatures {
            id: FrameId(id),
            timestamp: frame_stamp(id),
            point_descriptors: (0..self.points.len() as u64)
                .map(|i| descriptor(1, i))
                .collect(),
            line_descriptors: (0..self.lines.len() as u64)
                .map(|j| descriptor(2, j))
                .collect(),
            keypoints,
            lines,
            lines3d,
            manhattan: None,
            planes: Vec::new(),
            depth: Default::default(),
        }
    }
}

fn keypoint(u: f32, v: f32, depth: f32) -> KeyPoint {
    KeyPoint {
        u,
        v,
        level: 0,
        angle: 0.0,
        response: 1.0,
        depth,
    }
}

fn detected(segment: Segment) -> DetectedLine {
    DetectedLine {
        segment,
        mean_gradient: 50.0,
    }
}

/// `features` as tracked at `camera_from_world`, with no landmark links yet.
pub fn tracked(features: FrameFeatures, camera_from_world: Isometry3<f64>) -> TrackedFrame {
    let mut frame = TrackedFrame::untracked(features, camera_from_world);
    frame.status = TrackingStatus::Tracked;
    frame
}

/// A keyframe of `features` at `camera_from_world`, linked to nothing.
pub fn unlinked(features: FrameFeatures, camera_from_world: Isometry3<f64>) -> KeyFrame {
    KeyFrame {
        id: KeyFrameId(0),
        camera_from_world,
        point_ids: vec![None; features.keypoints.len()],
        line_ids: vec![None; features.lines.len()],
        plane_ids: vec![None; features.planes.len()],
        features,
        loop_correction: Isometry3::identity(),
    }
}

/// A map started by the mapper from the scene seen at the identity: one keyframe whose
/// keypoints and lines all became landmarks.
pub fn first_keyframe(scene: &Scene, config: &OdometryConfig) -> (Map, Mapper, KeyFrameId) {
    let mut map = Map::default();
    let mut mapper = Mapper::new(config, camera(), scale());
    let frame = tracked(
        scene.features(0, &Isometry3::identity()),
        Isometry3::identity(),
    );
    let kf = mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false));
    (map, mapper, kf)
}

/// The frame of `keyframe` linked to the keyframe's landmarks, as tracking it again
/// would give.
pub fn relinked(keyframe: &KeyFrame) -> TrackedFrame {
    let mut frame = tracked(keyframe.features.clone(), keyframe.camera_from_world);
    frame.point_ids = keyframe.point_ids.clone();
    frame.line_ids = keyframe.line_ids.clone();
    frame.plane_ids = keyframe.plane_ids.clone();
    frame.inliers.points = frame.point_ids.iter().flatten().count();
    frame.inliers.lines = frame.line_ids.iter().flatten().count();
    frame
}

/// The BFS planes a frame at `camera_from_world` would give of the planes `n . x = d`
/// (normals towards the camera, centroids on the plane 2 m ahead), exact.
pub fn planes_of(
    camera_from_world: &Isometry3<f64>,
    planes: &[([f64; 3], f64)],
) -> Vec<gfs_planes::Plane> {
    planes
        .iter()
        .map(|(n, d)| {
            let mut n_c = camera_from_world.rotation * Vector3::from(*n);
            let mut offset = -d - n_c.dot(&camera_from_world.translation.vector);
            if offset < 0.0 {
                n_c = -n_c;
                offset = -offset;
            }
            let ahead = Vector3::new(0.0, 0.0, 2.0);
            let centroid = ahead - (n_c.dot(&ahead) + offset) * n_c;
            gfs_planes::Plane {
                normal: n_c.cast::<f32>().into(),
                offset: offset as f32,
                pixels: 20_000,
                centroid: centroid.cast::<f32>().into(),
            }
        })
        .collect()
}

/// A map started by the mapper from a frame at the identity that sees only the planes
/// `n . x = d` (no point, no line): one keyframe, one map plane per plane.
pub fn plane_map(planes: &[([f64; 3], f64)]) -> (Map, KeyFrameId) {
    let mut map = Map::default();
    let mut mapper = Mapper::new(&OdometryConfig::default(), camera(), scale());
    let features = FrameFeatures {
        planes: planes_of(&Isometry3::identity(), planes),
        ..FrameFeatures::default()
    };
    let frame = tracked(features, Isometry3::identity());
    let kf = mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false));
    (map, kf)
}
