//! A calibrated camera (pinhole intrinsics plus lens) and the `[camera]` table of a
//! config file it is built and validated from.

use super::{Distortion, DistortionModel, PinholeCamera};
use nalgebra::Point2;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Camera parameters as written in a config file (`[camera]` table).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point column, pixels.
    pub cx: f64,
    /// Principal point row, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// The lens model, by its CameraInfo name: `plumb_bob` (default),
    /// `rational_polynomial` or `equidistant`.
    #[serde(default)]
    pub model: DistortionModel,
    /// Radial r^2 coefficient (equidistant: theta^2; default 0).
    #[serde(default)]
    pub k1: f64,
    /// Radial r^4 coefficient (equidistant: theta^4; default 0).
    #[serde(default)]
    pub k2: f64,
    /// Tangential coefficient 1 (default 0; not in equidistant).
    #[serde(default)]
    pub p1: f64,
    /// Tangential coefficient 2 (default 0; not in equidistant).
    #[serde(default)]
    pub p2: f64,
    /// Radial r^6 coefficient (equidistant: theta^6; default 0).
    #[serde(default)]
    pub k3: f64,
    /// Rational denominator r^2 coefficient (equidistant: theta^8; not in plumb_bob;
    /// default 0).
    #[serde(default)]
    pub k4: f64,
    /// Rational denominator r^4 coefficient (rational_polynomial only; default 0).
    #[serde(default)]
    pub k5: f64,
    /// Rational denominator r^6 coefficient (rational_polynomial only; default 0).
    #[serde(default)]
    pub k6: f64,
    /// Rolling-shutter readout time, first row to last, seconds (default 0: a global
    /// shutter). The tracker re-times each observation to the middle row with the
    /// camera's angular velocity.
    #[serde(default)]
    pub readout_s: f64,
}

impl CameraConfig {
    /// An ideal pinhole camera (no distortion, global shutter).
    pub fn pinhole(fx: f64, fy: f64, cx: f64, cy: f64, width: usize, height: usize) -> Self {
        Self {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
            model: DistortionModel::PlumbBob,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
            k4: 0.0,
            k5: 0.0,
            k6: 0.0,
            readout_s: 0.0,
        }
    }

    /// The lens of the table.
    pub fn distortion(&self) -> Distortion {
        Distortion {
            model: self.model,
            k1: self.k1,
            k2: self.k2,
            k3: self.k3,
            k4: self.k4,
            k5: self.k5,
            k6: self.k6,
            p1: self.p1,
            p2: self.p2,
        }
    }
}

/// A camera config value that cannot describe a camera.
#[derive(Debug, Error, PartialEq)]
pub enum CameraConfigError {
    /// A field is out of its valid range.
    #[error("camera.{field} = {} is invalid: {reason}", short(*value))]
    InvalidField {
        /// Field name in the `[camera]` table.
        field: &'static str,
        /// The value found.
        value: f64,
        /// What a valid value is.
        reason: &'static str,
    },
    /// The coefficients are finite but no lens has them.
    #[error("camera.model = \"{model}\" with {coefficients}: {reason}")]
    Lens {
        /// The model's name.
        model: &'static str,
        /// The model's coefficients, `k1 = .., ..`.
        coefficients: String,
        /// What is wrong with them.
        reason: String,
    },
}

/// `value` as a config would write it, in exponent form when the plain form is long.
fn short(value: f64) -> String {
    let plain = value.to_string();
    if plain.len() > 12 {
        format!("{value:e}")
    } else {
        plain
    }
}

/// Largest image side: a larger image is no RGB-D camera's, and its undistortion table
/// alone would take gigabytes.
pub const MAX_IMAGE_SIDE: usize = 8192;

/// The lens check samples the ideal image on a grid of this many cells a side.
const LENS_GRID: usize = 64;

/// Share of the ideal image whose source must lie inside the raw image: below it, the
/// coefficients would leave most of every frame black.
const MIN_SHARE_INSIDE: f64 = 0.5;

/// A calibrated camera: pinhole intrinsics plus lens distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics of the ideal (undistorted) image.
    pub pinhole: PinholeCamera,
    /// Lens distortion of the raw image.
    pub distortion: Distortion,
}

impl Camera {
    /// Builds and validates a camera from its config.
    ///
    /// # Errors
    /// [`CameraConfigError::InvalidField`] naming the first field that is not finite or
    /// out of range (non-positive focal length, size of 0 or above [`MAX_IMAGE_SIDE`],
    /// principal point outside the image, a coefficient the model does not have);
    /// [`CameraConfigError::Lens`] for a lens that folds over inside the image or sends
    /// most of it outside the raw image.
    pub fn from_config(c: &CameraConfig) -> Result<Self, CameraConfigError> {
        let check = |field, value: f64, ok: bool, reason| {
            if value.is_finite() && ok {
                Ok(())
            } else {
                Err(CameraConfigError::InvalidField {
                    field,
                    value,
                    reason,
                })
            }
        };
        let side = |n: usize| (1..=MAX_IMAGE_SIDE).contains(&n);
        let side_reason = "must be between 1 and 8192 pixels";
        check("width", c.width as f64, side(c.width), side_reason)?;
        check("height", c.height as f64, side(c.height), side_reason)?;
        check("fx", c.fx, c.fx > 0.0, "must be > 0")?;
        check("fy", c.fy, c.fy > 0.0, "must be > 0")?;
        check(
            "cx",
            c.cx,
            c.cx >= 0.0 && c.cx < c.width as f64,
            "must lie inside the image",
        )?;
        check(
            "cy",
            c.cy,
            c.cy >= 0.0 && c.cy < c.height as f64,
            "must lie inside the image",
        )?;
        check(
            "readout_s",
            c.readout_s,
            (0.0..=1.0).contains(&c.readout_s),
            "must be a time in seconds between 0 and 1",
        )?;
        let distortion = c.distortion();
        let used = distortion.model.coefficient_names();
        for (field, v) in distortion.named_coefficients() {
            check(field, v, true, "must be finite")?;
            let reason = match distortion.model {
                DistortionModel::PlumbBob => "plumb_bob has k1 k2 p1 p2 k3 only",
                DistortionModel::RationalPolynomial => "",
                DistortionModel::Equidistant => "equidistant has k1 k2 k3 k4 only",
            };
            check(field, v, v == 0.0 || used.contains(&field), reason)?;
        }
        let camera = Self {
            pinhole: PinholeCamera::new(c.fx, c.fy, c.cx, c.cy, c.width, c.height),
            distortion,
        };
        camera.check_lens()?;
        Ok(camera)
    }

    /// The `[camera]` table of this camera with `readout_s`.
    pub fn config(&self, readout_s: f64) -> CameraConfig {
        let (p, d) = (&self.pinhole, &self.distortion);
        CameraConfig {
            model: d.model,
            k1: d.k1,
            k2: d.k2,
            p1: d.p1,
            p2: d.p2,
            k3: d.k3,
            k4: d.k4,
            k5: d.k5,
            k6: d.k6,
            readout_s,
            ..CameraConfig::pinhole(p.fx, p.fy, p.cx, p.cy, p.width, p.height)
        }
    }

    /// Refuses coefficients that are finite but describe no usable lens: the ideal image
    /// must mostly read inside the raw one, and the lens must not fold over (the
    /// distorted radius grows along the ray to the farthest corner).
    fn check_lens(&self) -> Result<(), CameraConfigError> {
        if self.distortion.is_zero() {
            return Ok(());
        }
        let k = &self.pinhole;
        let (w, h) = (k.width as f64, k.height as f64);
        let error = |reason: String| CameraConfigError::Lens {
            model: self.distortion.model.name(),
            coefficients: self
                .distortion
                .model
                .coefficient_names()
                .iter()
                .zip(self.distortion.coefficients())
                .map(|(n, v)| format!("{n} = {}", short(v)))
                .collect::<Vec<_>>()
                .join(", "),
            reason,
        };
        let mut inside = 0usize;
        for i in 0..LENS_GRID {
            for j in 0..LENS_GRID {
                let ideal = Point2::new(
                    (i as f64 + 0.5) / LENS_GRID as f64 * w - 0.5,
                    (j as f64 + 0.5) / LENS_GRID as f64 * h - 0.5,
                );
                let raw = self.distort_pixel(ideal);
                inside += usize::from(
                    raw.x >= -0.5 && raw.y >= -0.5 && raw.x <= w - 0.5 && raw.y <= h - 0.5,
                );
            }
        }
        let share = inside as f64 / (LENS_GRID * LENS_GRID) as f64;
        if share < MIN_SHARE_INSIDE {
            return Err(error(format!(
                "{:.0} % of the undistorted image would read outside the raw image",
                100.0 * (1.0 - share)
            )));
        }
        let corner = [
            (0.0, 0.0),
            (w - 1.0, 0.0),
            (0.0, h - 1.0),
            (w - 1.0, h - 1.0),
        ]
        .map(|(u, v)| k.normalized(u, v))
        .into_iter()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .unwrap_or_default();
        let mut previous = 0.0;
        for step in 1..=LENS_GRID {
            let radius = self
                .distortion
                .distort(corner * (step as f64 / LENS_GRID as f64))
                .norm();
            // NaN (an overflowing lens) folds over too.
            if radius.partial_cmp(&previous) != Some(std::cmp::Ordering::Greater) {
                return Err(error(format!(
                    "the lens folds over {:.0} % of the way from the centre to the corner",
                    100.0 * step as f64 / LENS_GRID as f64
                )));
            }
            previous = radius;
        }
        Ok(())
    }

    /// Maps a raw (distorted) pixel to its position in the ideal pinhole image.
    pub fn undistort_pixel(&self, raw: Point2<f64>) -> Point2<f64> {
        let k = &self.pinhole;
        let p = self.distortion.undistort(k.normalized(raw.x, raw.y));
        Point2::new(k.fx * p.x + k.cx, k.fy * p.y + k.cy)
    }

    /// Maps an ideal pinhole pixel to where the lens puts it in the raw image.
    pub fn distort_pixel(&self, ideal: Point2<f64>) -> Point2<f64> {
        let k = &self.pinhole;
        let p = self.distortion.distort(k.normalized(ideal.x, ideal.y));
        Point2::new(k.fx * p.x + k.cx, k.fy * p.y + k.cy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published TUM freiburg1 calibration (strongest distortion of the TUM cameras).
    pub(crate) fn fr1() -> CameraConfig {
        CameraConfig {
            k1: 0.262383,
            k2: -0.953104,
            p1: -0.005358,
            p2: 0.002628,
            k3: 1.163314,
            ..CameraConfig::pinhole(517.306408, 516.469215, 318.643040, 255.313989, 640, 480)
        }
    }

    /// An Azure Kinect colour camera's rational_polynomial calibration (1280x720).
    fn azure_kinect() -> CameraConfig {
        CameraConfig {
            model: DistortionModel::RationalPolynomial,
            k1: 0.5164,
            k2: -2.6184,
            p1: 0.00046,
            p2: -0.00017,
            k3: 1.5022,
            k4: 0.3955,
            k5: -2.4455,
            k6: 1.4336,
            ..CameraConfig::pinhole(605.0, 604.8, 639.0, 366.5, 1280, 720)
        }
    }

    /// A wide fisheye (equidistant) lens, 848x800 as a T265's.
    fn fisheye() -> CameraConfig {
        CameraConfig {
            model: DistortionModel::Equidistant,
            k1: -0.0074,
            k2: 0.0424,
            k3: -0.0395,
            k4: 0.0068,
            ..CameraConfig::pinhole(286.2, 286.3, 416.5, 403.3, 848, 800)
        }
    }

    #[test]
    fn every_model_round_trips_within_a_hundredth_of_a_pixel_over_the_image() {
        for (name, config) in [
            ("plumb_bob", fr1()),
            ("rational_polynomial", azure_kinect()),
            ("equidistant", fisheye()),
        ] {
            let cam = Camera::from_config(&config).unwrap();
            assert_eq!(cam.distortion.model.name(), name);
            let (mut worst, mut moved) = (0.0f64, 0.0f64);
            for v in (0..cam.pinhole.height).step_by(4) {
                for u in (0..cam.pinhole.width).step_by(4) {
                    let ideal = Point2::new(u as f64, v as f64);
                    let raw = cam.distort_pixel(ideal);
                    worst = worst.max((cam.undistort_pixel(raw) - ideal).norm());
                    moved = moved.max((raw - ideal).norm());
                }
            }
            assert!(worst < 0.01, "{name}: worst round-trip error {worst} px");
            assert!(moved > 5.0, "{name}: the lens moves pixels ({moved} px)");
        }
    }

    #[test]
    fn invalid_config_names_the_field() {
        let mut c = CameraConfig::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480);
        c.fy = -1.0;
        let e = Camera::from_config(&c).unwrap_err();
        assert!(e.to_string().contains("camera.fy"), "{e}");
        c.fy = 500.0;
        c.cx = f64::NAN;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("camera.cx"), "{e}");
        c.cx = 320.0;
        c.readout_s = -0.01;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("camera.readout_s"), "{e}");
        c.readout_s = 0.0;
        c.width = 70_000;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("camera.width = 70000"), "{e}");
    }

    #[test]
    fn coefficients_of_no_usable_lens_are_refused() {
        let mut c = fr1();
        c.k1 = 1e300;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(
            e.starts_with("camera.model = \"plumb_bob\" with k1 = 1e300")
                && e.contains("outside the raw image"),
            "{e}"
        );
        let mut c = fr1();
        c.k2 = -40.0;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("folds over"), "{e}");
        let mut c = fr1();
        c.k4 = 0.1;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert_eq!(
            e,
            "camera.k4 = 0.1 is invalid: plumb_bob has k1 k2 p1 p2 k3 only"
        );
        let mut c = fisheye();
        c.p1 = 0.01;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("camera.p1") && e.contains("equidistant"), "{e}");
        let mut c = azure_kinect();
        c.k6 = f64::INFINITY;
        let e = Camera::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("camera.k6 = inf"), "{e}");
    }

    #[test]
    fn the_table_of_a_camera_builds_the_same_camera() {
        for config in [fr1(), azure_kinect(), fisheye()] {
            let cam = Camera::from_config(&config).unwrap();
            assert_eq!(cam.config(config.readout_s), config);
        }
    }
}
