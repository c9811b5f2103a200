//! Test fixtures: a box room rendered as depth from inside, Kinect-like noise and holes.
#![allow(dead_code)] // Each test binary uses a subset of the fixtures.

use gfs_core::Image;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// TUM fr1 intrinsics, 640 x 480, the camera of the benchmark sequence.
pub fn fr1_camera() -> PinholeCamera {
    PinholeCamera::new(517.3, 516.5, 318.6, 255.3, 640, 480)
}

/// splitmix64: a small, good-enough PRNG for fixtures (no `rand` dependency).
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

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box-Muller).
    pub fn gaussian(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// A uniformly random rotation (random unit quaternion).
    pub fn rotation(&mut self) -> Rotation3<f64> {
        let q = nalgebra::Quaternion::new(
            self.gaussian(),
            self.gaussian(),
            self.gaussian(),
            self.gaussian(),
        );
        UnitQuaternion::from_quaternion(q).to_rotation_matrix()
    }
}

/// An axis-aligned box room `[min, max]` (world frame, metres), seen from inside.
pub struct BoxRoom {
    pub min: Vector3<f64>,
    pub max: Vector3<f64>,
}

impl BoxRoom {
    /// A 5 x 2.8 x 4 m office-sized room centred on the origin.
    pub fn office() -> Self {
        Self {
            min: Vector3::new(-2.5, -1.4, -2.0),
            max: Vector3::new(2.5, 1.4, 2.0),
        }
    }

    /// Ray-casts the depth image from `world_from_camera` (inside the room) and the wall
    /// each pixel sees: `2 * axis + (1 if the max side)`.
    pub fn render(
        &self,
        camera: &PinholeCamera,
        world_from_camera: &Isometry3<f64>,
    ) -> (Image<f32>, Vec<u8>) {
        let r = world_from_camera.rotation.to_rotation_matrix();
        let c = world_from_camera.translation.vector;
        let mut depth = Image::new(camera.width, camera.height);
        let mut walls = vec![0u8; camera.width * camera.height];
        for v in 0..camera.height {
            for u in 0..camera.width {
                let ray_c = camera.back_project(u as f64, v as f64, 1.0).coords;
                let ray_w = r * ray_c;
                let mut best = (f64::INFINITY, 0u8);
                for a in 0..3 {
                    let (t, wall) = if ray_w[a] > 1e-12 {
                        ((self.max[a] - c[a]) / ray_w[a], 2 * a as u8 + 1)
                    } else if ray_w[a] < -1e-12 {
                        ((self.min[a] - c[a]) / ray_w[a], 2 * a as u8)
                    } else {
                        continue;
                    };
                    if t < best.0 {
                        best = (t, wall);
                    }
                }
                // The ray has z = 1 in the camera frame, so t is the depth.
                depth.set(u, v, best.0 as f32);
                walls[v * camera.width + u] = best.1;
            }
        }
        (depth, walls)
    }

    /// Normal of `wall` towards the room's inside (towards any camera in it), in the
    /// camera frame.
    pub fn wall_normal_in_camera(wall: u8, world_from_camera: &Isometry3<f64>) -> Vector3<f64> {
        let mut n = Vector3::zeros();
        n[(wall / 2) as usize] = if wall % 2 == 1 { -1.0 } else { 1.0 };
        world_from_camera.rotation.inverse() * n
    }
}

/// The room's axes in the camera frame: `camera_from_world` rotation.
pub fn true_axes(world_from_camera: &Isometry3<f64>) -> Matrix3<f64> {
    world_from_camera
        .rotation
        .inverse()
        .to_rotation_matrix()
        .into_inner()
}

/// A pose at `position` with rotation `r`.
pub fn pose(position: Vector3<f64>, r: Rotation3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(position),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// Kinect-like depth noise, sigma = 1.425e-3 z^2 (Nguyen et al. 2012), and holes: each
/// pixel missing with probability `hole_fraction`, plus `blobs` missing 40 x 30 boxes.
pub fn add_kinect_noise(depth: &mut Image<f32>, rng: &mut Rng, hole_fraction: f64, blobs: usize) {
    for z in depth.as_mut_slice() {
        if *z > 0.0 {
            let zf = f64::from(*z);
            *z = (zf + 1.425e-3 * zf * zf * rng.gaussian()) as f32;
        }
        if rng.uniform() < hole_fraction {
            *z = 0.0;
        }
    }
    let (w, h) = (depth.width(), depth.height());
    for _ in 0..blobs {
        let x0 = (rng.uniform() * w.saturating_sub(40) as f64) as usize;
        let y0 = (rng.uniform() * h.saturating_sub(30) as f64) as usize;
        for y in y0..(y0 + 30).min(h) {
            for x in x0..(x0 + 40).min(w) {
                depth.set(x, y, 0.0);
            }
        }
    }
}

/// Angle in degrees between two unit vectors, ignoring sign when `unsigned`.
pub fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>, unsigned: bool) -> f64 {
    let c = a.dot(b) / (a.norm() * b.norm());
    let c = if unsigned { c.abs() } else { c };
    c.clamp(-1.0, 1.0).acos().to_degrees()
}
