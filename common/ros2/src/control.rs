//! Requests to the run from ROS 2, checked: a reset to a pose (`geometry_msgs/
//! PoseWithCovarianceStamped`, as rtabmap's `initialpose`) turned into the camera pose
//! the tracker starts the new map from, and a pose hint in the loaded map (`/initialpose`,
//! as RViz's "2D Pose Estimate" sends it) turned into the camera pose the tracker
//! relocalises near.

use crate::msg::PoseWithCovarianceStamped;
use crate::odom::{OdometryPublisherState, from_pose};
use gfs_core::stamp::Stamp;
use nalgebra::Isometry3;

/// How far a quaternion's norm may be from 1 (what float32 tools round to) before the
/// pose is refused rather than normalised.
const UNIT_TOLERANCE: f64 = 1e-3;

/// The camera pose (`world_from_camera`, odometry frame) of a reset to the base pose
/// in `message`, received on `topic`.
///
/// # Errors
/// A message naming the topic and the stamp: a value not finite, a quaternion whose
/// norm is not 1, or a frame other than the odometry's (or the map's, which a reset
/// makes the same).
pub fn reset_pose(
    message: &PoseWithCovarianceStamped,
    topic: &str,
    odometry: &OdometryPublisherState,
) -> Result<Isometry3<f64>, String> {
    let (odom_frame, map_frame) = odometry.frames();
    checked_camera_pose(message, odometry, &["", odom_frame, map_frame])
        .map_err(|why| refused(message, topic, &why, "reset refused"))
}

/// The camera pose (`world_from_camera` in the loaded map's frame) of a pose hint for
/// the base in `message`, received on `topic`.
///
/// # Errors
/// A message naming the topic and the stamp: a value not finite, a quaternion whose
/// norm is not 1, or a frame other than the map's.
pub fn hint_pose(
    message: &PoseWithCovarianceStamped,
    topic: &str,
    odometry: &OdometryPublisherState,
) -> Result<Isometry3<f64>, String> {
    let (_, map_frame) = odometry.frames();
    checked_camera_pose(message, odometry, &[map_frame])
        .map_err(|why| refused(message, topic, &why, "pose hint refused"))
}

fn refused(message: &PoseWithCovarianceStamped, topic: &str, why: &str, what: &str) -> String {
    let stamp = Stamp::from(message.header.stamp);
    format!("{topic} at {stamp}: {why}; {what}")
}

/// The camera pose of the base pose in `message` when it is finite, its quaternion of
/// unit norm and its frame one of `frames`; otherwise why not.
fn checked_camera_pose(
    message: &PoseWithCovarianceStamped,
    odometry: &OdometryPublisherState,
    frames: &[&str],
) -> Result<Isometry3<f64>, String> {
    let pose = &message.pose.pose;
    let (p, q) = (&pose.position, &pose.orientation);
    let values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w];
    if !values.iter().all(|v| v.is_finite()) {
        return Err(format!("the pose {values:?} is not finite"));
    }
    let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    if (norm - 1.0).abs() > UNIT_TOLERANCE {
        return Err(format!(
            "the orientation's norm is {norm:.4}, not 1 (a unit quaternion)"
        ));
    }
    let frame = message.header.frame_id.as_str();
    if !frames.contains(&frame) {
        let named: Vec<&str> = frames.iter().copied().filter(|f| !f.is_empty()).collect();
        return Err(format!("the pose is in frame {frame:?}, not {named:?}"));
    }
    Ok(odometry.camera_in_odom(&from_pose(pose)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Ros2Config;
    use crate::msg::{Header, Pose, PoseWithCovariance, Quaternion, Time, Vector3};
    use crate::odom::TrackedPose;

    fn message(
        frame: &str,
        position: [f64; 3],
        orientation: [f64; 4],
    ) -> PoseWithCovarianceStamped {
        let [x, y, z] = position;
        let [qx, qy, qz, qw] = orientation;
        PoseWithCovarianceStamped {
            header: Header {
                stamp: Time {
                    sec: 1_700_000_000,
                    nanosec: 123_456_789,
                },
                frame_id: frame.to_owned(),
            },
            pose: PoseWithCovariance {
                pose: Pose {
                    position: Vector3 { x, y, z },
                    orientation: Quaternion {
                        x: qx,
                        y: qy,
                        z: qz,
                        w: qw,
                    },
                },
                covariance: [0.0; 36],
            },
        }
    }

    #[test]
    fn the_base_pose_becomes_the_camera_pose_odom_then_publishes() {
        let mut odometry = OdometryPublisherState::new(&Ros2Config::default());
        let half = std::f64::consts::FRAC_1_SQRT_2;
        let given = message("odom", [1.0, -2.0, 0.5], [0.0, 0.0, half, half]);
        let camera = reset_pose(&given, "/gfsvo/reset_to_pose", &odometry).expect("valid");
        let published = odometry
            .messages(&TrackedPose {
                stamp: Stamp::from_nanos(1),
                world_from_camera: camera,
                covariance: None,
                status: "tracked",
                map_from_odom: Isometry3::identity(),
            })
            .odometry
            .expect("an odometry");
        let (p, q) = (
            &published.pose.pose.position,
            &published.pose.pose.orientation,
        );
        let error = [
            p.x - 1.0,
            p.y + 2.0,
            p.z - 0.5,
            q.x,
            q.y,
            q.z - half,
            q.w - half,
        ]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            error < 1e-12,
            "/odom is the given base pose (off by {error})"
        );
    }

    #[test]
    fn nan_non_unit_quaternions_and_other_frames_are_refused_naming_topic_and_stamp() {
        let odometry = OdometryPublisherState::new(&Ros2Config::default());
        let topic = "/gfsvo/reset_to_pose";
        for (bad, why) in [
            (
                message("odom", [f64::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
                "not finite",
            ),
            (
                message("odom", [0.0; 3], [0.0, 0.0, 0.0, 2.0]),
                "norm is 2.0000",
            ),
            (message("odom", [0.0; 3], [0.0; 4]), "norm is 0.0000"),
            (
                message("camera_link", [0.0; 3], [0.0, 0.0, 0.0, 1.0]),
                "\"camera_link\"",
            ),
        ] {
            let e = reset_pose(&bad, topic, &odometry).expect_err(why);
            assert!(
                e.contains(topic) && e.contains("1700000000.123456789") && e.contains(why),
                "{e}"
            );
        }
        for frame in ["", "odom", "map"] {
            let ok = message(frame, [0.0; 3], [0.0, 0.0, 0.0, 1.0]);
            assert!(reset_pose(&ok, topic, &odometry).is_ok(), "{frame:?}");
        }
    }

    #[test]
    fn a_pose_hint_is_taken_in_map_only_and_becomes_the_camera_pose_there() {
        let odometry = OdometryPublisherState::new(&Ros2Config::default());
        let topic = "/initialpose";
        let half = std::f64::consts::FRAC_1_SQRT_2;
        let given = message("map", [1.0, -2.0, 0.0], [0.0, 0.0, half, half]);
        let camera = hint_pose(&given, topic, &odometry).expect("a pose in map");
        // The base pose again from the camera pose: what /odom would say in map.
        let base = odometry.base_in_odom(&camera);
        let expected = from_pose(&given.pose.pose);
        let error = (base.translation.vector - expected.translation.vector).norm()
            + base.rotation.angle_to(&expected.rotation);
        assert!(error < 1e-12, "the hint is the base pose given ({error})");
        for (bad, why) in [
            (message("odom", [0.0; 3], [0.0, 0.0, 0.0, 1.0]), "\"odom\""),
            (message("", [0.0; 3], [0.0, 0.0, 0.0, 1.0]), "\"\""),
            (
                message("map", [0.0, f64::INFINITY, 0.0], [0.0, 0.0, 0.0, 1.0]),
                "not finite",
            ),
            (
                message("map", [0.0; 3], [0.0, 0.0, 0.5, 0.5]),
                "norm is 0.7071",
            ),
        ] {
            let e = hint_pose(&bad, topic, &odometry).expect_err(why);
            assert!(
                e.contains(topic)
                    && e.contains("1700000000.123456789")
                    && e.contains(why)
                    && e.ends_with("pose hint refused"),
                "{e}"
            );
        }
    }
}
