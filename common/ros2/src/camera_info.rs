//! `sensor_msgs/CameraInfo` as the pipeline's camera: K gives the pinhole, plumb_bob D
//! (k1 k2 p1 p2 k3) the distortion. A message with zeros where a camera needs values
//! (an uncalibrated driver publishes K = 0) is refused, naming the topic and stamp.

use crate::msg::CameraInfo;
use gfs_core::camera::{Camera, CameraConfig};

/// A CameraInfo that cannot describe the camera.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{topic} at {stamp:.6} s: {reason}")]
pub struct CameraInfoError {
    /// The topic.
    pub topic: String,
    /// The header stamp, seconds.
    pub stamp: f64,
    /// What is wrong.
    pub reason: String,
}

/// The camera `info` describes; `readout_s` (rolling shutter) is not in CameraInfo and
/// comes from the config.
///
/// # Errors
/// [`CameraInfoError`] for a zero or invalid K or size, a distortion model other than
/// plumb_bob (or none), or a distortion vector of another length.
pub fn camera_from_info(
    info: &CameraInfo,
    topic: &str,
    readout_s: f64,
) -> Result<Camera, CameraInfoError> {
    let error = |reason: String| CameraInfoError {
        topic: topic.to_owned(),
        stamp: info.header.stamp.secs(),
        reason,
    };
    if info.k.iter().all(|&v| v == 0.0) {
        return Err(error("K is all zeros (uncalibrated camera)".to_owned()));
    }
    let d = &info.d;
    let distortion = match info.distortion_model.as_str() {
        _ if d.iter().all(|&v| v == 0.0) => [0.0; 5],
        "plumb_bob" | "rational_polynomial" if d.len() >= 5 && d[5..].iter().all(|&v| v == 0.0) => {
            [d[0], d[1], d[2], d[3], d[4]]
        }
        model => {
            return Err(error(format!(
                "distortion model {model:?} with D = {d:?}: only plumb_bob (k1 k2 p1 p2 k3) is supported"
            )));
        }
    };
    let config = CameraConfig {
        fx: info.k[0],
        fy: info.k[4],
        cx: info.k[2],
        cy: info.k[5],
        width: info.width as usize,
        height: info.height as usize,
        k1: distortion[0],
        k2: distortion[1],
        p1: distortion[2],
        p2: distortion[3],
        k3: distortion[4],
        readout_s,
    };
    Camera::from_config(&config).map_err(|e| error(e.to_string()))
}

/// True when two cameras differ by more than rounding (1e-6 relative on every value).
pub fn cameras_differ(a: &Camera, b: &Camera) -> bool {
    let (p, q) = (&a.pinhole, &b.pinhole);
    let (d, e) = (&a.distortion, &b.distortion);
    let far = |x: f64, y: f64| (x - y).abs() > 1e-6 * x.abs().max(y.abs()).max(1.0);
    (p.width, p.height) != (q.width, q.height)
        || far(p.fx, q.fx)
        || far(p.fy, q.fy)
        || far(p.cx, q.cx)
        || far(p.cy, q.cy)
        || far(d.k1, e.k1)
        || far(d.k2, e.k2)
        || far(d.p1, e.p1)
        || far(d.p2, e.p2)
        || far(d.k3, e.k3)
}

/// The CameraInfo of `camera` (what `gfsvo convert` writes into a bag).
pub fn info_from_camera(camera: &Camera, header: crate::msg::Header) -> CameraInfo {
    let p = &camera.pinhole;
    let d = &camera.distortion;
    CameraInfo {
        header,
        height: p.height as u32,
        width: p.width as u32,
        distortion_model: "plumb_bob".to_owned(),
        d: vec![d.k1, d.k2, d.p1, d.p2, d.k3],
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
    use gfs_core::camera::{Distortion, PinholeCamera};

    fn fr1() -> Camera {
        Camera {
            pinhole: PinholeCamera::new(517.3, 516.5, 318.6, 255.3, 640, 480),
            distortion: Distortion {
                k1: 0.26,
                k2: -0.95,
                p1: -0.005,
                p2: 0.003,
                k3: 1.16,
            },
        }
    }

    fn header() -> Header {
        Header {
            stamp: Time { sec: 3, nanosec: 0 },
            frame_id: "cam".to_owned(),
        }
    }

    #[test]
    fn camera_info_round_trips_the_camera() {
        let info = info_from_camera(&fr1(), header());
        let camera = camera_from_info(&info, "/info", 0.02).unwrap();
        assert!(!cameras_differ(&camera, &fr1()));
        let mut other = fr1();
        other.pinhole.fx += 1.0;
        assert!(cameras_differ(&camera, &other));
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
        info.distortion_model = "equidistant".to_owned();
        info.d.truncate(4);
        assert!(
            camera_from_info(&info, "/info", 0.0)
                .unwrap_err()
                .reason
                .contains("equidistant")
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
    }
}
