use super::*;
use crate::cdr;
use crate::msg::Time;

fn topics() -> ImuTopics {
    ImuTopics {
        unified: "/camera/imu".to_owned(),
        gyro: "/camera/gyro/sample".to_owned(),
        accel: "/camera/accel/sample".to_owned(),
    }
}

fn message(nanos: i64, gyro: [f64; 3], accel: [f64; 3]) -> Imu {
    let v = |a: [f64; 3]| Vector3 {
        x: a[0],
        y: a[1],
        z: a[2],
    };
    Imu {
        header: Header {
            stamp: Stamp::from_nanos(nanos).into(),
            frame_id: "imu".to_owned(),
        },
        angular_velocity: v(gyro),
        linear_acceleration: v(accel),
        ..Imu::default()
    }
}

#[test]
fn bad_unified_messages_are_dropped_and_good_ones_kept() {
    let mut input = ImuInput::new(topics());
    let mut out = Vec::new();
    let ms = 1_000_000;
    for (t, g) in [
        (10, 0.1),
        (15, 0.2),
        (15, 0.3),      // repeated
        (12, 0.4),      // backwards
        (20, f64::NAN), // not finite
        (25, 0.5),
        (1500, 0.6), // a gap: kept
    ] {
        input.push(
            ImuTopic::Unified,
            &message(t * ms, [g, 0.0, 0.0], [0.0, 0.0, 9.81]),
            &mut out,
        );
    }
    let mut bad = message(30 * ms, [0.0; 3], [0.0; 3]);
    bad.header.stamp = Time {
        sec: 0,
        nanosec: 2_000_000_000,
    };
    input.push(ImuTopic::Unified, &bad, &mut out);
    let kept: Vec<(i64, f64)> = out
        .iter()
        .map(|s| (s.stamp.nanos() / ms, s.gyro.x))
        .collect();
    assert_eq!(kept, [(10, 0.1), (15, 0.2), (25, 0.5), (1500, 0.6)]);
    assert_eq!(input.received(), 8);
    // The separate topics are ignored once the unified one spoke.
    input.push(
        ImuTopic::Gyro,
        &message(1600 * ms, [1.0; 3], [0.0; 3]),
        &mut out,
    );
    input.push(
        ImuTopic::Accel,
        &message(1700 * ms, [0.0; 3], [1.0; 3]),
        &mut out,
    );
    assert_eq!(out.len(), 4);
}

#[test]
fn gyro_at_400_hz_and_accel_at_100_hz_are_united_at_the_gyro_stamps() {
    let mut input = ImuInput::new(topics());
    let mut out = Vec::new();
    let start = 1_700_000_000_000_000_000_i64;
    // Accelerometer linear in time: a_x = t (s after start); gyro z = sample index.
    let (mut g, mut a) = (0_i64, 0_i64);
    while a <= 100 {
        // Interleaved roughly as a driver sends them: by stamp.
        if g * 2_500_000 <= a * 10_000_000 {
            let t = start + g * 2_500_000;
            input.push(
                ImuTopic::Gyro,
                &message(t, [0.0, 0.0, g as f64], [0.0; 3]),
                &mut out,
            );
            g += 1;
        } else {
            let t = start + a * 10_000_000;
            let secs = a as f64 * 0.01;
            input.push(
                ImuTopic::Accel,
                &message(t, [0.0; 3], [secs, 0.0, 9.81]),
                &mut out,
            );
            a += 1;
        }
    }
    // Every gyro sample from the first accel stamp to the last one: 1 s at 400 Hz.
    assert_eq!(out.len(), 401);
    for s in &out {
        let secs = s.stamp.secs_since(Stamp::from_nanos(start));
        assert!((s.accel.x - secs).abs() < 1e-9, "{} at {secs}", s.accel.x);
        assert_eq!(s.accel.z, 9.81);
        assert!((s.gyro.z - (secs / 0.0025).round()).abs() < 1e-9);
    }
}

#[test]
fn an_outgoing_message_says_no_orientation_and_the_noise_and_reads_back() {
    let sample = ImuSample {
        stamp: Stamp::from_nanos(1_305_031_102_175_304_001),
        gyro: nalgebra::Vector3::new(0.1, -0.2, 0.3),
        accel: nalgebra::Vector3::new(0.0, -9.81, 0.2),
    };
    let noise = ImuNoise::default();
    let m = imu_message(&sample, "camera_imu_optical_frame", &noise, 200.0);
    assert_eq!(m.orientation_covariance[0], -1.0);
    let gyro_var = noise.gyro_noise.powi(2) * 200.0;
    assert!((m.angular_velocity_covariance[4] - gyro_var).abs() < 1e-18);
    assert_eq!(m.angular_velocity_covariance[1], 0.0);
    let mut bytes = Vec::new();
    cdr::encode_into(&m, "sensor_msgs/Imu", &mut bytes).unwrap();
    let back: Imu = cdr::decode(&bytes, "sensor_msgs/Imu").unwrap();
    assert_eq!(back, m);
    assert_eq!(
        Stamp::from(back.header.stamp).nanos(),
        1_305_031_102_175_304_001
    );
}
