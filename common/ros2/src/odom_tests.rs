use super::*;
use crate::config::OPTICAL_IN_BASE;
use nalgebra::{Matrix6, Vector3 as V3, Vector6};

fn pose(stamp: f64, x_optical_z: f64, status: &'static str) -> TrackedPose {
    TrackedPose {
        stamp: Stamp::from_secs(stamp).unwrap(),
        world_from_camera: Isometry3::translation(0.0, 0.0, x_optical_z),
        covariance: Some(Matrix6::from_diagonal(&Vector6::new(
            1.0, 2.0, 3.0, 4.0, 5.0, 6.0,
        ))),
        status,
        map_from_odom: Isometry3::identity(),
    }
}

#[test]
fn the_default_extrinsic_is_rep_103_optical_to_body() {
    let state = OdometryPublisherState::new(&Ros2Config::default());
    let b = state.camera_in_base;
    // optical z (forward) = base x, optical x (right) = base -y, optical y (down) = base -z.
    assert!(
        (b * nalgebra::Point3::new(0.0, 0.0, 1.0) - nalgebra::Point3::new(1.0, 0.0, 0.0)).norm()
            < 1e-12
    );
    assert!((b.rotation * V3::x() + V3::y()).norm() < 1e-12);
    assert!((b.rotation * V3::y() + V3::z()).norm() < 1e-12);
    assert_eq!(Ros2Config::default().camera_in_base, OPTICAL_IN_BASE);
}

#[test]
fn camera_moving_forward_is_the_base_moving_along_x_with_its_covariance_rotated() {
    let mut state = OdometryPublisherState::new(&Ros2Config::default());
    let first = state.messages(&pose(10.0, 0.0, "tracked"));
    let odom = first.odometry.unwrap();
    assert_eq!(odom.header.frame_id, "odom");
    assert_eq!(odom.child_frame_id, "base_link");
    assert_eq!(
        odom.header.stamp,
        Time {
            sec: 10,
            nanosec: 0
        }
    );
    let m = state.messages(&pose(10.5, 1.0, "tracked"));
    let odom = m.odometry.unwrap();
    let p = odom.pose.pose.position;
    assert!(
        (p.x - 1.0).abs() < 1e-12 && p.y.abs() < 1e-12 && p.z.abs() < 1e-12,
        "{p:?}"
    );
    // Camera (x, y, z) variances 1, 2, 3 are base (y, z, x): 3, 1, 2; rotations 6, 4, 5.
    let c = odom.pose.covariance;
    let diag: Vec<f64> = (0..6).map(|i| c[i * 7]).collect();
    for (got, want) in diag.iter().zip([3.0, 1.0, 2.0, 6.0, 4.0, 5.0]) {
        assert!((got - want).abs() < 1e-12, "{diag:?}");
    }
    assert!(
        (odom.twist.twist.linear.x - 2.0).abs() < 1e-9,
        "1 m in 0.5 s"
    );
    assert!((odom.twist.covariance[0] - (3.0 + 3.0) / 0.25).abs() < 1e-9);
    let tf = m.tf.unwrap();
    assert_eq!(tf.transforms[0].child_frame_id, "base_link");
    assert_eq!(tf.transforms[0].transform.translation, p);
    assert_eq!(m.status.data, "tracked");
}

#[test]
fn a_lost_frame_publishes_the_prediction_inflated_or_nothing() {
    let mut state = OdometryPublisherState::new(&Ros2Config::default());
    let mut lost = pose(1.0, 0.0, "predicted");
    lost.covariance = None;
    let odom = state.messages(&lost).odometry.unwrap();
    assert_eq!(odom.pose.covariance[0], 1e4);
    let config = Ros2Config {
        when_lost: WhenLost::Nothing,
        publish_tf: false,
        ..Ros2Config::default()
    };
    let mut state = OdometryPublisherState::new(&config);
    let m = state.messages(&lost);
    assert_eq!(
        (m.odometry, m.tf, m.status.data.as_str()),
        (None, None, "predicted")
    );
    assert!(state.messages(&pose(2.0, 0.0, "tracked")).tf.is_none());
}

#[test]
fn odometry_survives_a_cdr_round_trip_byte_for_byte() {
    let mut state = OdometryPublisherState::new(&Ros2Config::default());
    let m = state.messages(&pose(3.25, 0.5, "tracked"));
    let odom = m.odometry.unwrap();
    let mut bytes = Vec::new();
    crate::cdr::encode_into(&odom, "Odometry", &mut bytes).unwrap();
    // Encapsulation 4, then (aligned from after it) stamp 8, "odom\0" 4 + 5, pad 3,
    // "base_link\0" 4 + 10, pad 6 to the 8-byte floats, pose 56 + 288, twist 48 + 288.
    assert_eq!(bytes.len(), 4 + 8 + 9 + 3 + 14 + 6 + 56 + 288 + 48 + 288);
    let back: Odometry = crate::cdr::decode(&bytes, "Odometry").unwrap();
    assert_eq!(back, odom);
    let tf = m.tf.unwrap();
    crate::cdr::encode_into(&tf, "TFMessage", &mut bytes).unwrap();
    assert_eq!(
        crate::cdr::decode::<TfMessage>(&bytes, "TFMessage").unwrap(),
        tf
    );
    assert!(crate::cdr::decode::<Odometry>(&bytes[..40], "Odometry").is_err());
    assert!(crate::cdr::decode::<Odometry>(&[0, 0, 0, 0, 1], "Odometry").is_err());
    assert!(crate::cdr::decode::<Odometry>(&[0, 1], "Odometry").is_err());
}

#[test]
fn a_loop_correction_is_published_as_map_to_odom_in_base_axes() {
    let mut state = OdometryPublisherState::new(&Ros2Config::default());
    assert_eq!(
        state
            .messages(&pose(1.0, 0.0, "tracked"))
            .tf
            .unwrap()
            .transforms
            .len(),
        1
    );
    // 5 cm along the optical z (forward) in the pipeline's world: along the base's x.
    let corrected = TrackedPose {
        map_from_odom: Isometry3::translation(0.0, 0.0, 0.05),
        ..pose(2.0, 0.1, "tracked")
    };
    let tf = state.messages(&corrected).tf.unwrap();
    let map_to_odom = &tf.transforms[1];
    assert_eq!(
        (
            map_to_odom.header.frame_id.as_str(),
            map_to_odom.child_frame_id.as_str()
        ),
        ("map", "odom")
    );
    let t = &map_to_odom.transform.translation;
    assert!(
        (t.x - 0.05).abs() < 1e-12 && t.y.abs() < 1e-12 && t.z.abs() < 1e-12,
        "{t:?}"
    );
}
