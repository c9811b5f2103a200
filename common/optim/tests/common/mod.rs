//! Synthetic fixtures shared by the integration tests and the benchmark example: a
//! PRNG, a camera, scenes of points and axis-aligned lines, noisy observations.
#![allow(dead_code)]

use gfs_core::camera::PinholeCamera;
use gfs_core::se3::exp;
use nalgebra::{Isometry3, Point3, Vector2, Vector3, Vector6};

/// splitmix64 plus Box-Muller: deterministic random numbers without dependencies.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn gaussian(&mut self) -> f64 {
        let u1 = self.uniform(1e-12, 1.0);
        let u2 = self.uniform(0.0, 1.0);
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    pub fn gaussian3(&mut self, sigma: f64) -> Vector3<f64> {
        Vector3::new(self.gaussian(), self.gaussian(), self.gaussian()) * sigma
    }

    pub fn unit3(&mut self) -> Vector3<f64> {
        loop {
            let v = self.gaussian3(1.0);
            if v.norm() > 1e-6 {
                return v.normalize();
            }
        }
    }
}

/// A Kinect-like camera (TUM fr1 intrinsics rounded), 640x480.
pub fn camera() -> PinholeCamera {
    PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
}

/// The three Manhattan axes of the synthetic scenes.
pub const AXES: [Vector3<f64>; 3] = [
    Vector3::new(1.0, 0.0, 0.0),
    Vector3::new(0.0, 1.0, 0.0),
    Vector3::new(0.0, 0.0, 1.0),
];

/// `camera_from_world` moved by `translation` metres and `angle` radians in random
/// directions.
pub fn perturb(
    pose: &Isometry3<f64>,
    translation: f64,
    angle: f64,
    rng: &mut Rng,
) -> Isometry3<f64> {
    let t = rng.unit3() * translation;
    let r = rng.unit3() * angle;
    exp(&Vector6::new(t.x, t.y, t.z, r.x, r.y, r.z)) * pose
}

/// Distance between the camera centres (metres) and the rotation angle (degrees)
/// between two `camera_from_world` poses.
pub fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let ca = a.inverse().translation.vector;
    let cb = b.inverse().translation.vector;
    let dr = a.rotation * b.rotation.inverse();
    ((ca - cb).norm(), dr.angle().to_degrees())
}

/// World point seen at pixel `uv` at `depth` by `camera_from_world`.
pub fn point_at_pixel(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    uv: Vector2<f64>,
    depth: f64,
) -> Vector3<f64> {
    let p_c = camera.back_project(uv.x, uv.y, depth);
    (camera_from_world.inverse() * p_c).coords
}

/// Pixel of a world point, if it projects inside the image with a 10 px border.
pub fn project(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    p_w: &Vector3<f64>,
) -> Option<Vector2<f64>> {
    let uv = camera.project(&(camera_from_world * Point3::from(*p_w)))?;
    camera.contains(uv.x, uv.y, 10.0).then_some(uv.coords)
}

/// Normalised line coefficients through two pixels (as `gfs_lines::Segment`).
pub fn line_through(a: Vector2<f64>, b: Vector2<f64>) -> Vector3<f64> {
    let d = b - a;
    let n = Vector2::new(d.y, -d.x) / d.norm();
    Vector3::new(n.x, n.y, -n.dot(&a))
}

/// A noisy observation of a world line: both endpoints inside the image, at least
/// 30 px long, each endpoint moved by `noise_px` Gaussian pixels.
pub fn observe_line(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    line: &[Vector3<f64>; 2],
    noise_px: f64,
    rng: &mut Rng,
) -> Option<Vector3<f64>> {
    let a = project(camera, camera_from_world, &line[0])?;
    let b = project(camera, camera_from_world, &line[1])?;
    if (a - b).norm() < 30.0 {
        return None;
    }
    let noise = |rng: &mut Rng| Vector2::new(rng.gaussian(), rng.gaussian()) * noise_px;
    Some(line_through(a + noise(rng), b + noise(rng)))
}

/// A line of `axis` direction, `length` metres, centred at `centre`.
pub fn axis_line(centre: Vector3<f64>, axis: usize, length: f64) -> [Vector3<f64>; 2] {
    let half = AXES[axis] * (0.5 * length);
    [centre - half, centre + half]
}

/// Angle in degrees between a line's direction and an axis (sign-free).
pub fn direction_error_deg(line: &[Vector3<f64>; 2], axis: &Vector3<f64>) -> f64 {
    let d = (line[1] - line[0]).normalize();
    d.dot(axis).abs().min(1.0).acos().to_degrees()
}
