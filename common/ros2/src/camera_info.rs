//! `sensor_msgs/CameraInfo` as the pipeline's camera: K gives the pinhole, the
//! distortion model and D the lens (plumb_bob, rational_polynomial or equidistant, the
//! models camera drivers publish). A message with zeros where a camera needs values (an
//! uncalibrated driver publishes K = 0), or another model, is refused, naming the topic
//! and stamp.

use crate::msg::CameraInfo;
use gfs_core::camera::{Camera, CameraConfigError, Distortion, DistortionModel, PinholeCamera};

/// A CameraInfo that cannot describe the camera.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{topic} at {stamp} s: {reason}")]
pub struct CameraInfoError {
    /// The topic.
    pub topic: String,
    /// The header stamp.
    pub stamp: gfs_core::stamp::Stamp,
    /// What is wrong.
    pub reason: String,
}

/// The camera `info` describes; `readout_s` (rolling shutter) is not in CameraInfo and
/// comes from the config.
///
/// # Errors
/// [`CameraInfoError`] for a zero or invalid K or size, a distortion model other than
/// plumb_bob, rational_polynomial and equidistant (or none, with D empty or zero), a D
/// with coefficients the model does not have, or a lens that cannot be undistorted.
pub fn camera_from_info(
    info: &CameraInfo,
    topic: &str,
    readout_s: f64,
) -> Result<Camera, CameraInfoError> {
    let error = |reason: String| CameraInfoError {
        topic: topic.to_owned(),
        stamp: info.header.stamp.into(),
        reason,
    };
    if info.k.iter().all(|&v| v == 0.0) {
        return Err(error("K is all zeros (uncalibrated camera)".to_owned()));
    }
    let d = &info.d;
    let model = match DistortionModel::from_name(&info.distortion_model) {
        Some(model) => model,
        None if info.distortion_model.is_empty() && d.iter().all(|&v| v == 0.0) => {
            DistortionModel::PlumbBob
        }
        None => {
            let known = DistortionModel::ALL.map(DistortionModel::name).join(", ");
            return Err(error(format!(
                "distortion model {:?} is not one of {known}",
                info.distortion_model
            )));
        }
    };
    let used = model.coefficient_names().len();
    if d.len() > used && d[used..].iter().any(|&v| v != 0.0) {
        return Err(error(format!(
            "D = {d:?} has {} values; {} has {used} ({})",
            d.len(),
            model.name(),
            model.coefficient_names().join(" ")
        )));
    }
    let width = info.width as usize;
    let height = info.height as usize;
    let config = Camera {
        pinhole: PinholeCamera::new(info.k[0], info.k[4], info.k[2], info.k[5], width, height),
        distortion: Distortion::from_coefficients(model, d),
    }
    .config(readout_s);
    Camera::from_config(&config).map_err(|e| error(in_message_terms(e, model)))
}

/// A camera config error in the CameraInfo's own field names (K[0], D[2], width).
fn in_message_terms(e: CameraConfigError, model: DistortionModel) -> String {
    let text = e.to_string();
    let CameraConfigError::InvalidField { field, .. } = e else {
        return text.replacen("camera.model", "distortion_model", 1);
    };
    let k = ["fx", "cx", "fy", "cy"].iter().position(|&f| f == field);
    let d = model.coefficient_names().iter().position(|&f| f == field);
    let name = match (k, d) {
        (Some(i), _) => format!("K[{}]", [0, 2, 4, 5][i]),
        (None, Some(i)) => format!("D[{i}]"),
        (None, None) => field.to_owned(),
    };
    text.replacen(&format!("camera.{field}"), &name, 1)
}

/// True when two cameras differ by more than rounding (1e-6 relative on every value)
/// or in their lens model.
pub fn cameras_differ(a: &Camera, b: &Camera) -> bool {
    let (p, q) = (&a.pinhole, &b.pinhole);
    let (d, e) = (&a.distortion, &b.distortion);
    let far = |x: f64, y: f64| (x - y).abs() > 1e-6 * x.abs().max(y.abs()).max(1.0);
    (p.width, p.height) != (q.width, q.height)
        || d.model != e.model
        || far(p.fx, q.fx)
        || far(p.fy, q.fy)
        || far(p.cx, q.cx)
        || far(p.cy, q.cy)
        || d.named_coefficients()
            .iter()
            .zip(e.named_coefficients())
            .any(|((_, x), (_, y))| far(*x, y))
}

/// The CameraInfo of `camera` (what `gfsvo convert` writes into a bag).
pub fn info_from_camera(camera: &Camera, header: crate::msg::Header) -> CameraInfo {
    let p = &camera.pinhole;
    let d = &camera.distortion;
    CameraInfo {
        header,
        height: p.height as u32,
        width: p.width as u32,
        distortion_model: d.model.name().to_owned(),
        d: d.coefficients(),
        k: [p.fx, 0.0, p.cx, 0.0, p.fy, p.cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [
            p.fx, 0.0, p.cx, 0.0, 0.0, p.fy, p.cy, 0.0, 0.0, 0.0, 1.0, 0.0,
        ],
        binning_x: 0,
        binning_y: 0,
        roi: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Header, Time};

    fn fr1() -> Camera {
        Camera {
            pinhole: PinholeCamera::new(517.3, 516.5, 318.6, 255.3, 640, 480),
            distortion: Distortion::from_coefficients(
                DistortionModel::PlumbBob,
                &[0.26, -0.95, -0.005, 0.003, 1.16],
            ),
        }
    }

    fn header() -> Header {
        Header {
            stamp: Time { sec: 3, nanosec: 0 },
            frame_id: "cam".to_owned(),
        }
    }

    #[test]
    fn camera_info_round_trips_every_model() {
        let rational = Distortion::from_coefficients(
            DistortionModel::RationalPolynomial,
            &[0.52, -2.6, 0.0005, -0.0002, 1.5, 0.4, -2.4, 1.4],
        );
        let fisheye = Distortion::from_coefficients(
            DistortionModel::Equidistant,
            &[-0.007, 0.04, -0.04, 0.007],
        );
        for distortion in [fr1().distortion, rational, fisheye] {
            let camera = Camera {
                distortion,
                ..fr1()
            };
            let info = info_from_camera(&camera, header());
            assert_eq!(info.distortion_model, distortion.model.name());
            assert_eq!(info.d.len(), distortion.model.coefficient_names().len());
            let back = camera_from_info(&info, "/info", 0.02).unwrap();
            assert!(!cameras_differ(&camera, &back), "{:?}", distortion.model);
        }
        let mut other = fr1();
        other.pinhole.fx += 1.0;
        assert!(cameras_differ(&fr1(), &other));
        let mut other = fr1();
        other.distortion.model = DistortionModel::RationalPolynomial;
        assert!(cameras_differ(&fr1(), &other));
    }

    #[test]
    fn zeros_and_unknown_models_are_refused_naming_topic_and_stamp() {
        let mut info = info_from_camera(&fr1(), header());
        info.k = [0.0; 9];
        let e = camera_from_info(&info, "/info", 0.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "/info at 3.000000 s: K is all zeros (uncalibrated camera)"
        );
        let mut info = info_from_camera(&fr1(), header());
        info.width = 0;
        assert!(
            camera_from_info(&info, "/info", 0.0)
                .unwrap_err()
                .reason
                .contains("width")
        );
        let mut info = info_from_camera(&fr1(), header());
        info.distortion_model = "kannala_brandt".to_owned();
        info.d.truncate(4);
        assert_eq!(
            camera_from_info(&info, "/camera/info", 0.0)
                .unwrap_err()
                .to_string(),
            "/camera/info at 3.000000 s: distortion model \"kannala_brandt\" is not one of \
             plumb_bob, rational_polynomial, equidistant"
        );
        let mut info = info_from_camera(&fr1(), header());
        info.d = vec![0.0; 5];
        info.distortion_model = String::new();
        assert!(
            camera_from_info(&info, "/info", 0.0)
                .unwrap()
                .distortion
                .is_zero()
        );
        let mut info = info_from_camera(&fr1(), header());
        info.d.extend([0.1, 0.0, 0.0]);
        let e = camera_from_info(&info, "/info", 0.0).unwrap_err();
        assert!(e.reason.contains("plumb_bob has 5"), "{e}");
    }

    #[test]
    fn a_huge_or_wild_camera_is_blamed_on_the_message_fields() {
        let mut info = info_from_camera(&fr1(), header());
        (info.width, info.height) = (70_000, 70_000);
        let e = camera_from_info(&info, "/info", 0.0).unwrap_err();
        assert_eq!(
            e.reason,
            "width = 70000 is invalid: must be between 1 and 8192 pixels"
        );
        let mut info = info_from_camera(&fr1(), header());
        info.k[0] = -1.0;
        let e = camera_from_info(&info, "/info", 0.0).unwrap_err();
        assert_eq!(e.reason, "K[0] = -1 is invalid: must be > 0");
        let mut info = info_from_camera(&fr1(), header());
        info.d[0] = 1e300;
        let e = camera_from_info(&info, "/info", 0.0).unwrap_err();
        assert!(
            e.reason
                .starts_with("distortion_model = \"plumb_bob\" with k1 = 1e300"),
            "{e}"
        );
    }
}
