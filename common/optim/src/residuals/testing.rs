//! Test helpers: a small PRNG, random configurations and the numeric Jacobian check.

use gfs_core::camera::PinholeCamera;
use gfs_core::se3::exp;
use nalgebra::{Isometry3, Point3, SMatrix, SVector, Vector3, Vector6};

/// A VGA Kinect-like pinhole camera (TUM's nominal intrinsics).
pub(crate) fn vga_camera() -> PinholeCamera {
    PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
}

/// Deterministic random numbers for fixtures ([`gfs_core::rng::SplitMix64`]).
pub(crate) struct SplitMix64(gfs_core::rng::SplitMix64);

impl SplitMix64 {
    pub(crate) fn new(seed: u64) -> Self {
        Self(gfs_core::rng::SplitMix64::new(seed))
    }

    pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.range(lo, hi)
    }

    pub(crate) fn vector3(&mut self, half_range: f64) -> Vector3<f64> {
        Vector3::new(
            self.uniform(-half_range, half_range),
            self.uniform(-half_range, half_range),
            self.uniform(-half_range, half_range),
        )
    }
}

/// A Kinect-like camera and a random `camera_from_world`.
pub(crate) fn random_camera_and_pose(rng: &mut SplitMix64) -> (PinholeCamera, Isometry3<f64>) {
    let camera = PinholeCamera::new(
        rng.uniform(450.0, 600.0),
        rng.uniform(450.0, 600.0),
        rng.uniform(300.0, 340.0),
        rng.uniform(220.0, 260.0),
        640,
        480,
    );
    let xi = Vector6::new(
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
        rng.uniform(-1.5, 1.5),
        rng.uniform(-1.5, 1.5),
        rng.uniform(-1.5, 1.5),
    );
    (camera, exp(&xi))
}

/// A world point that lies 0.5-5 m in front of the camera, inside a 640x480 view.
pub(crate) fn random_point_in_view(
    rng: &mut SplitMix64,
    camera_from_world: &Isometry3<f64>,
) -> Vector3<f64> {
    let p_c = Point3::new(
        rng.uniform(-0.4, 0.4),
        rng.uniform(-0.3, 0.3),
        rng.uniform(0.5, 5.0),
    );
    let p_c = Point3::from(p_c.coords * p_c.z);
    (camera_from_world.inverse() * p_c).coords
}

/// Step of the central differences.
const NUMERIC_STEP: f64 = 1e-6;
/// Allowed difference, relative to the largest analytic entry (or absolute below 1).
const RELATIVE_TOLERANCE: f64 = 1e-6;

/// Checks an analytic Jacobian against central differences of `f` around zero.
pub(crate) fn assert_jacobian<const R: usize, const C: usize>(
    f: impl Fn(&SVector<f64, C>) -> SVector<f64, R>,
    analytic: &SMatrix<f64, R, C>,
    what: &str,
) {
    let mut numeric = SMatrix::<f64, R, C>::zeros();
    for k in 0..C {
        let mut d = SVector::<f64, C>::zeros();
        d[k] = NUMERIC_STEP;
        let plus = f(&d);
        d[k] = -NUMERIC_STEP;
        let minus = f(&d);
        numeric.set_column(k, &((plus - minus) / (2.0 * NUMERIC_STEP)));
    }
    let scale = analytic.amax().max(1.0);
    let diff = (numeric - analytic).amax();
    assert!(
        diff <= RELATIVE_TOLERANCE * scale,
        "{what}: max |numeric - analytic| = {diff:e} (scale {scale:e})\nanalytic {analytic}\nnumeric {numeric}"
    );
}
