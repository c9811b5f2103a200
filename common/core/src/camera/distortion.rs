//! The lens models ROS 2 camera drivers publish in `CameraInfo.distortion_model`, on
//! normalised points (the z = 1 plane), with OpenCV's meaning of every coefficient:
//!
//! - `plumb_bob`: radial-tangential (Brown-Conrady) k1 k2 p1 p2 k3;
//! - `rational_polynomial`: the same with the radial factor divided by
//!   `1 + k4 r^2 + k5 r^4 + k6 r^6` (RealSense, Azure Kinect, Orbbec);
//! - `equidistant`: the fisheye model, the ray's angle `theta` mapped to
//!   `theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)`.
//!
//! `plumb_bob` is `rational_polynomial` with k4 = k5 = k6 = 0, and is computed so.

use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

/// A lens model, by its CameraInfo name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistortionModel {
    /// k1 k2 p1 p2 k3 (default).
    #[default]
    PlumbBob,
    /// k1 k2 p1 p2 k3 k4 k5 k6.
    RationalPolynomial,
    /// Fisheye k1 k2 k3 k4.
    Equidistant,
}

impl DistortionModel {
    /// Every model, for error messages and parsing.
    pub const ALL: [Self; 3] = [Self::PlumbBob, Self::RationalPolynomial, Self::Equidistant];

    /// The CameraInfo / config name.
    pub fn name(self) -> &'static str {
        match self {
            Self::PlumbBob => "plumb_bob",
            Self::RationalPolynomial => "rational_polynomial",
            Self::Equidistant => "equidistant",
        }
    }

    /// The model of a CameraInfo / config name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The coefficients of the model, in CameraInfo `D` order.
    pub fn coefficient_names(self) -> &'static [&'static str] {
        match self {
            Self::PlumbBob => &["k1", "k2", "p1", "p2", "k3"],
            Self::RationalPolynomial => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
            Self::Equidistant => &["k1", "k2", "k3", "k4"],
        }
    }
}

/// Lens distortion: the model and its coefficients (those the model does not use are 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Distortion {
    /// Which model the coefficients belong to.
    pub model: DistortionModel,
    /// Radial r^2 coefficient (equidistant: theta^2).
    pub k1: f64,
    /// Radial r^4 coefficient (equidistant: theta^4).
    pub k2: f64,
    /// Radial r^6 coefficient (equidistant: theta^6).
    pub k3: f64,
    /// Rational denominator r^2 coefficient (equidistant: theta^8).
    pub k4: f64,
    /// Rational denominator r^4 coefficient.
    pub k5: f64,
    /// Rational denominator r^6 coefficient.
    pub k6: f64,
    /// Tangential coefficient 1.
    pub p1: f64,
    /// Tangential coefficient 2.
    pub p2: f64,
}

/// Newton iterations of [`Distortion::undistort`]; converges to 1e-12 well before this on
/// Kinect-like and fisheye lenses.
const UNDISTORT_MAX_ITERATIONS: usize = 20;

/// Below this radius (normalised) a point is on the axis: every model leaves it there.
const ON_AXIS: f64 = 1e-12;

impl Distortion {
    /// A distortion of `model` with its coefficients in CameraInfo `D` order (missing
    /// ones are 0, extra ones ignored).
    pub fn from_coefficients(model: DistortionModel, d: &[f64]) -> Self {
        let mut out = Self {
            model,
            ..Self::default()
        };
        for (name, &value) in model.coefficient_names().iter().zip(d) {
            *out.coefficient_mut(name) = value;
        }
        out
    }

    /// The coefficients of the model in CameraInfo `D` order.
    pub fn coefficients(&self) -> Vec<f64> {
        let names = self.model.coefficient_names();
        names.iter().map(|name| self.coefficient(name)).collect()
    }

    /// Every coefficient by name, used by the model or not.
    pub fn named_coefficients(&self) -> [(&'static str, f64); 8] {
        [
            ("k1", self.k1),
            ("k2", self.k2),
            ("k3", self.k3),
            ("k4", self.k4),
            ("k5", self.k5),
            ("k6", self.k6),
            ("p1", self.p1),
            ("p2", self.p2),
        ]
    }

    fn coefficient(&self, name: &str) -> f64 {
        let named = self.named_coefficients();
        named.iter().find(|(n, _)| *n == name).map_or(0.0, |c| c.1)
    }

    fn coefficient_mut(&mut self, name: &str) -> &mut f64 {
        match name {
            "k1" => &mut self.k1,
            "k2" => &mut self.k2,
            "k3" => &mut self.k3,
            "k4" => &mut self.k4,
            "k5" => &mut self.k5,
            "k6" => &mut self.k6,
            "p1" => &mut self.p1,
            _ => &mut self.p2,
        }
    }

    /// True when all coefficients are zero (no image remapping needed; for a fisheye,
    /// zero coefficients are still the equidistant projection, not a pinhole).
    pub fn is_zero(&self) -> bool {
        self.model != DistortionModel::Equidistant
            && self.named_coefficients().iter().all(|(_, v)| *v == 0.0)
    }

    /// Distorts a normalised point (z = 1 plane).
    #[inline]
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        match self.model {
            DistortionModel::Equidistant => {
                let r = p.norm();
                if r < ON_AXIS {
                    return p;
                }
                p * (self.fisheye_angle(r.atan()) / r)
            }
            _ => {
                let (x, y) = (p.x, p.y);
                let r2 = x * x + y * y;
                let radial = self.radial(r2).0;
                Vector2::new(
                    x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
                    y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
                )
            }
        }
    }

    /// The rational radial factor at `r2` and its derivative with respect to `r2`.
    #[inline]
    fn radial(&self, r2: f64) -> (f64, f64) {
        let num = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let den = 1.0 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6));
        let dnum = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let dden = self.k4 + r2 * (2.0 * self.k5 + 3.0 * r2 * self.k6);
        (num / den, (dnum * den - num * dden) / (den * den))
    }

    /// The equidistant model's distorted angle of a ray at `theta`.
    #[inline]
    fn fisheye_angle(&self, theta: f64) -> f64 {
        let t2 = theta * theta;
        theta * (1.0 + t2 * (self.k1 + t2 * (self.k2 + t2 * (self.k3 + t2 * self.k4))))
    }

    /// Jacobian of the radial-tangential [`Self::distort`] at a normalised point.
    fn radial_tangential_jacobian(&self, p: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let (radial, dradial) = self.radial(r2);
        let dxx = radial + 2.0 * x * x * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxy = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyy = radial + 2.0 * y * y * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxx, dxy, dxy, dyy)
    }

    /// Inverts [`Self::distort`] by Newton's method, starting at the distorted point
    /// (for the fisheye, on the angle alone: the model is radial).
    pub fn undistort(&self, distorted: Vector2<f64>) -> Vector2<f64> {
        if self.is_zero() {
            return distorted;
        }
        match self.model {
            DistortionModel::Equidistant => self.undistort_fisheye(distorted),
            _ => self.undistort_radial_tangential(distorted),
        }
    }

    fn undistort_radial_tangential(&self, distorted: Vector2<f64>) -> Vector2<f64> {
        let mut p = distorted;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let residual = self.distort(p) - distorted;
            if residual.norm_squared() < 1e-24 {
                break;
            }
            let Some(inv) = self.radial_tangential_jacobian(p).try_inverse() else {
                break;
            };
            p -= inv * residual;
        }
        p
    }

    fn undistort_fisheye(&self, distorted: Vector2<f64>) -> Vector2<f64> {
        let theta_d = distorted.norm();
        if theta_d < ON_AXIS {
            return distorted;
        }
        let mut theta = theta_d;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let t2 = theta * theta;
            let residual = self.fisheye_angle(theta) - theta_d;
            if residual.abs() < 1e-12 {
                break;
            }
            let slope = 1.0
                + t2 * (3.0 * self.k1
                    + t2 * (5.0 * self.k2 + t2 * (7.0 * self.k3 + t2 * 9.0 * self.k4)));
            if slope.abs() < ON_AXIS {
                break;
            }
            theta = (theta - residual / slope).clamp(0.0, std::f64::consts::FRAC_PI_2 - 1e-9);
        }
        distorted * (theta.tan() / theta_d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plumb_bob_is_rational_polynomial_without_a_denominator() {
        let d = [0.26, -0.95, -0.005, 0.003, 1.16];
        let plumb_bob = Distortion::from_coefficients(DistortionModel::PlumbBob, &d);
        let rational = Distortion::from_coefficients(DistortionModel::RationalPolynomial, &d);
        let p = Vector2::new(0.4, -0.3);
        assert_eq!(plumb_bob.distort(p), rational.distort(p));
        assert_eq!(plumb_bob.coefficients(), d);
        assert_eq!(rational.coefficients(), [&d[..], &[0.0; 3]].concat());
    }

    #[test]
    fn the_fisheye_maps_angles_not_radii() {
        let fisheye = Distortion::from_coefficients(DistortionModel::Equidistant, &[0.0; 4]);
        assert!(
            !fisheye.is_zero(),
            "equidistant with zeros is still a fisheye"
        );
        // A ray at 45 degrees lands at radius pi/4 (not tan 45 = 1).
        let d = fisheye.distort(Vector2::new(1.0, 0.0));
        assert!((d.x - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        let back = fisheye.undistort(d);
        assert!((back.x - 1.0).abs() < 1e-9, "{back}");
    }

    #[test]
    fn the_jacobian_matches_finite_differences_for_the_rational_model() {
        let d = Distortion::from_coefficients(
            DistortionModel::RationalPolynomial,
            &[0.5, -2.6, 0.001, -0.0005, 1.5, 0.4, -2.4, 1.4],
        );
        let p = Vector2::new(0.3, 0.2);
        let j = d.radial_tangential_jacobian(p);
        let h = 1e-7;
        for axis in 0..2 {
            let mut step = Vector2::zeros();
            step[axis] = h;
            let numeric = (d.distort(p + step) - d.distort(p - step)) / (2.0 * h);
            assert!((numeric - j.column(axis)).norm() < 1e-6, "{numeric} vs {j}");
        }
    }
}
