//! What a user sees in RViz / Foxglove besides `/odom`: the map points
//! (`/gfsvo/landmarks`, PointCloud2 x y z rgb coloured by height), the lines, plane
//! patches and Manhattan axes (`/gfsvo/structure`, MarkerArray), the keyframe poses
//! (`/gfsvo/keyframes`, Path in `map`) and the odometry so far (`/gfsvo/path`, Path in
//! `odom`). Built from a [`Scene`] of the map and the published poses: the frames of
//! REP 105 as [`crate::odom`] uses them (`odom` is the base at the first image). Of each
//! frame ([`frame`]): its matched points in the camera frame (`/gfsvo/frame_points`)
//! and the tracking image (`/gfsvo/tracking_image`).

pub mod frame;
pub mod msg;

use crate::config::Ros2Config;
use crate::msg::{Header, Pose, Quaternion, Time, Vector3};
use gfs_core::scene::Scene;
use gfs_core::stamp::Stamp;
use msg::{
    ADD, ColorRgba, FLOAT32, LINE_LIST, Marker, MarkerArray, Path, PointCloud2, PointField,
    PoseStamped, TRIANGLE_LIST,
};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use serde::Deserialize;

/// Topic of the map points.
pub const LANDMARKS_TOPIC: &str = "/gfsvo/landmarks";
/// Topic of the lines, planes and axes.
pub const STRUCTURE_TOPIC: &str = "/gfsvo/structure";
/// Topic of the keyframe poses.
pub const KEYFRAMES_TOPIC: &str = "/gfsvo/keyframes";
/// Topic of the odometry path.
pub const PATH_TOPIC: &str = "/gfsvo/path";

/// Bytes of a landmark: x y z rgb, four float32.
pub const POINT_STEP: u32 = 16;
/// Width of the line markers, metres.
const LINE_WIDTH_M: f64 = 0.01;
/// Length of the drawn Manhattan axes, metres.
const AXIS_LENGTH_M: f64 = 0.5;
/// Opacity of the plane patches.
const PLANE_ALPHA: f32 = 0.4;
/// Colours of the Manhattan axes 0, 1, 2 (red, green, blue) and of structure without.
const AXIS_COLORS: [[f32; 3]; 3] = [[0.85, 0.15, 0.15], [0.1, 0.65, 0.2], [0.15, 0.3, 0.9]];
const NO_AXIS_COLOR: [f32; 3] = [0.5, 0.5, 0.5];
/// Viridis at 0, 1/4, 1/2, 3/4, 1: the height colours of the landmarks.
const VIRIDIS: [[f32; 3]; 5] = [
    [0.267, 0.005, 0.329],
    [0.229, 0.322, 0.546],
    [0.128, 0.567, 0.551],
    [0.369, 0.789, 0.383],
    [0.993, 0.906, 0.144],
];

/// `[ros2.visualisation]`: which visualisation topics `gfsvo ros2` publishes and
/// `gfsvo run --mcap` records.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VisualisationConfig {
    /// `/gfsvo/landmarks` on every keyframe.
    pub landmarks: bool,
    /// `/gfsvo/structure` on every keyframe.
    pub structure: bool,
    /// `/gfsvo/keyframes` on every keyframe.
    pub keyframes: bool,
    /// `/gfsvo/path`, at `path_rate_hz` of the data's clock (and after the last frame).
    pub path: bool,
    /// Rate of `/gfsvo/path`, Hz of the data's stamps.
    pub path_rate_hz: f64,
    /// `/gfsvo/frame_points` on every frame.
    pub frame_points: bool,
    /// `/gfsvo/tracking_image` at `tracking_image_rate_hz` of the data's clock.
    pub tracking_image: bool,
    /// Rate of the tracking image, Hz of the data's stamps.
    pub tracking_image_rate_hz: f64,
    /// `raw`: `sensor_msgs/Image` rgb8 on `/gfsvo/tracking_image`; `jpeg`:
    /// `sensor_msgs/CompressedImage` on `/gfsvo/tracking_image/compressed`.
    pub tracking_image_format: frame::ImageFormat,
    /// The camera's optical frame of `/gfsvo/frame_points` and the tracking image when
    /// the colour images name none (dataset folders).
    pub camera_frame: String,
}

impl Default for VisualisationConfig {
    fn default() -> Self {
        Self {
            landmarks: true,
            structure: true,
            keyframes: true,
            path: true,
            path_rate_hz: 1.0,
            frame_points: true,
            tracking_image: true,
            tracking_image_rate_hz: 1.0,
            tracking_image_format: frame::ImageFormat::Raw,
            camera_frame: "camera_color_optical_frame".to_owned(),
        }
    }
}

impl VisualisationConfig {
    /// Rejects a rate that is not one.
    ///
    /// # Errors
    /// Naming the field and its value.
    pub fn validate(&self) -> Result<(), String> {
        for (field, rate) in [
            ("path_rate_hz", self.path_rate_hz),
            ("tracking_image_rate_hz", self.tracking_image_rate_hz),
        ] {
            if !(rate.is_finite() && rate > 0.0) {
                return Err(format!(
                    "ros2.visualisation.{field} = {rate} must be a positive number"
                ));
            }
        }
        if self.camera_frame.trim().is_empty() {
            return Err("ros2.visualisation.camera_frame must name a frame".to_owned());
        }
        Ok(())
    }
}

/// Builds the visualisation messages in the frames of a `[ros2]` config.
#[derive(Clone, Debug)]
pub struct Visualiser {
    /// The camera's optical frame in the base (`odom` is the base at the first image,
    /// the pipeline's world the first camera frame).
    camera_in_base: Isometry3<f64>,
    odom_frame: String,
    map_frame: String,
}

impl Visualiser {
    /// The builder for `config`'s frames.
    pub fn new(config: &Ros2Config) -> Self {
        let c = config.camera_in_base;
        let rotation =
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(c[6], c[3], c[4], c[5]));
        Self {
            camera_in_base: Isometry3::from_parts(Translation3::new(c[0], c[1], c[2]), rotation),
            odom_frame: config.odom_frame.clone(),
            map_frame: config.map_frame.clone(),
        }
    }

    fn header(stamp: Stamp, frame: &str) -> Header {
        Header {
            stamp: Time::from(stamp),
            frame_id: frame.to_owned(),
        }
    }

    /// A point of the pipeline's world in `odom` (or `map`).
    fn point(&self, p: &Point3<f64>) -> Point3<f64> {
        self.camera_in_base * p
    }

    /// A camera pose of the pipeline's world as the base's pose in `odom` (or `map`).
    fn pose(&self, world_from_camera: &Isometry3<f64>) -> Pose {
        let base = self.camera_in_base * world_from_camera * self.camera_in_base.inverse();
        let (t, q) = (base.translation.vector, base.rotation.into_inner());
        Pose {
            position: Vector3 {
                x: t.x,
                y: t.y,
                z: t.z,
            },
            orientation: Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        }
    }

    /// `/gfsvo/landmarks`: the finite map points in `odom`, coloured by height (z) from
    /// the 2nd to the 98th percentile.
    pub fn landmarks(&self, scene: &Scene, stamp: Stamp) -> PointCloud2 {
        let points: Vec<Point3<f32>> = scene
            .points
            .iter()
            .map(|p| self.point(p).cast::<f32>())
            .filter(|p| p.iter().all(|v| v.is_finite()))
            .collect();
        let mut heights: Vec<f32> = points.iter().map(|p| p.z).collect();
        heights.sort_unstable_by(f32::total_cmp);
        let at = |q: f32| {
            heights
                .get(((heights.len().saturating_sub(1)) as f32 * q).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let (lo, hi) = (at(0.02), at(0.98));
        let coloured = points.iter().map(|p| {
            let t = if hi > lo { (p.z - lo) / (hi - lo) } else { 0.5 };
            (*p, viridis(t).map(|c| (c * 255.0).round() as u8))
        });
        cloud(Self::header(stamp, &self.odom_frame), coloured)
    }

    /// `/gfsvo/structure`: the lines (LINE_LIST, namespace `lines`), the plane patches
    /// (TRIANGLE_LIST, two triangles each, `planes`), coloured by Manhattan axis, and the
    /// axes at the first keyframe (LINE_LIST, `axes`), in `odom`.
    pub fn structure(&self, scene: &Scene, stamp: Stamp) -> MarkerArray {
        let header = Self::header(stamp, &self.odom_frame);
        let marker = |ns: &str, kind, width: f64| Marker {
            header: header.clone(),
            ns: ns.to_owned(),
            kind,
            action: ADD,
            scale: Vector3 {
                x: width,
                y: width,
                z: width,
            },
            ..Marker::default()
        };
        let mut lines = marker("lines", LINE_LIST, LINE_WIDTH_M);
        for line in &scene.lines {
            for end in &line.ends {
                lines.points.push(self.vector(end));
                lines.colors.push(color(line.axis, 1.0));
            }
        }
        let mut planes = marker("planes", TRIANGLE_LIST, 1.0);
        for plane in &scene.planes {
            for k in [0, 1, 2, 0, 2, 3] {
                planes.points.push(self.vector(&plane.corners[k]));
                planes.colors.push(color(plane.axis, PLANE_ALPHA));
            }
        }
        let mut axes = marker("axes", LINE_LIST, 2.0 * LINE_WIDTH_M);
        if let Some(directions) = &scene.axes {
            let origin = scene
                .keyframes
                .first()
                .map_or_else(Point3::origin, |kf| Point3::from(kf.translation.vector));
            for (k, d) in directions.iter().enumerate() {
                axes.points.push(self.vector(&origin));
                axes.points.push(self.vector(&(origin + AXIS_LENGTH_M * d)));
                let c = color(Some(k as u8), 1.0);
                axes.colors.extend([c, c]);
            }
        }
        MarkerArray {
            markers: vec![lines, planes, axes],
        }
    }

    fn vector(&self, p: &Point3<f64>) -> Vector3 {
        let q = self.point(p);
        Vector3 {
            x: q.x,
            y: q.y,
            z: q.z,
        }
    }

    /// `/gfsvo/keyframes`: the keyframe poses of the map (after BA and loop correction)
    /// as base poses in `map`.
    pub fn keyframes(&self, scene: &Scene, stamp: Stamp) -> Path {
        let header = Self::header(stamp, &self.map_frame);
        Path {
            poses: scene
                .keyframes
                .iter()
                .map(|kf| PoseStamped {
                    header: header.clone(),
                    pose: self.pose(kf),
                })
                .collect(),
            header,
        }
    }

    /// `/gfsvo/path`: the published odometry `(stamp, world_from_camera)` so far as base
    /// poses in `odom`, each stamped with its frame's stamp.
    pub fn path(&self, poses: &[(Stamp, Isometry3<f64>)], stamp: Stamp) -> Path {
        Path {
            header: Self::header(stamp, &self.odom_frame),
            poses: poses
                .iter()
                .map(|(t, pose)| PoseStamped {
                    header: Self::header(*t, &self.odom_frame),
                    pose: self.pose(pose),
                })
                .collect(),
        }
    }
}

/// A PointCloud2 of x y z rgb float32 (PCL's packed colour) of `points`.
fn cloud(header: Header, points: impl Iterator<Item = (Point3<f32>, [u8; 3])>) -> PointCloud2 {
    let mut data = Vec::with_capacity(points.size_hint().0 * POINT_STEP as usize);
    for (p, [r, g, b]) in points {
        // PCL's packed colour: 0x00RRGGBB in the bits of a float32.
        let rgb = f32::from_bits((u32::from(r) << 16) | (u32::from(g) << 8) | u32::from(b));
        for v in [p.x, p.y, p.z, rgb] {
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    let field = |name: &str, offset| PointField {
        name: name.to_owned(),
        offset,
        datatype: FLOAT32,
        count: 1,
    };
    let width = (data.len() / POINT_STEP as usize) as u32;
    PointCloud2 {
        header,
        height: 1,
        width,
        fields: vec![
            field("x", 0),
            field("y", 4),
            field("z", 8),
            field("rgb", 12),
        ],
        is_bigendian: false,
        point_step: POINT_STEP,
        row_step: POINT_STEP * width,
        data,
        is_dense: true,
    }
}

/// The colour of Manhattan axis `axis` (grey without), with opacity `alpha`.
fn color(axis: Option<u8>, alpha: f32) -> ColorRgba {
    let [r, g, b] = axis.map_or(NO_AXIS_COLOR, |k| AXIS_COLORS[usize::from(k % 3)]);
    ColorRgba { r, g, b, a: alpha }
}

/// Viridis at `t` in 0..1 (clamped), linear between five stops.
fn viridis(t: f32) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    std::array::from_fn(|c| VIRIDIS[i][c] + f * (VIRIDIS[i + 1][c] - VIRIDIS[i][c]))
}

#[cfg(test)]
mod tests;
