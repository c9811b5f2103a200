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
