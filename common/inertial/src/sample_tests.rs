use super::*;

fn sample(t_ms: i64, value: f64) -> ImuSample {
    ImuSample {
        stamp: Stamp::from_nanos(t_ms * 1_000_000),
        gyro: Vector3::new(value, 0.0, 0.0),
        accel: Vector3::new(0.0, 0.0, 9.81),
    }
}

#[test]
fn bad_samples_are_dropped_with_the_reason_and_the_stream_goes_on() {
    let mut stream = ImuStream::new(0.05, 100);
    assert_eq!(stream.push(sample(0, 0.0)), Pushed::Kept);
    assert_eq!(stream.push(sample(5, 0.1)), Pushed::Kept);
    let repeated = stream.push(sample(5, 0.2));
    assert_eq!(
        repeated,
        Pushed::Dropped(SampleIssue::Repeated(Stamp::from_nanos(5_000_000)))
    );
    assert!(matches!(
        stream.push(sample(3, 0.3)),
        Pushed::Dropped(SampleIssue::Backwards { .. })
    ));
    let nan = stream.push(sample(10, f64::NAN));
    assert_eq!(
        nan,
        Pushed::Dropped(SampleIssue::NotFinite(Stamp::from_nanos(10_000_000)))
    );
    // A second missing: kept, and said.
    match stream.push(sample(1010, 0.4)) {
        Pushed::KeptWith(SampleIssue::Gap { gap_s, .. }) => assert!((gap_s - 1.005).abs() < 1e-9),
        other => panic!("{other:?}"),
    }
    assert_eq!(stream.samples().len(), 3);
    // The driver restarts its clock: the buffer starts again.
    assert!(matches!(
        stream.push(sample(2, 0.5)),
        Pushed::KeptWith(SampleIssue::Restarted { .. })
    ));
    assert_eq!(stream.samples().len(), 1);
}

#[test]
fn the_buffer_is_bounded_and_keeps_the_sample_an_interval_starts_from() {
    let mut stream = ImuStream::new(0.05, 10);
    for k in 0..25 {
        stream.push(sample(k * 5, k as f64));
    }
    assert_eq!(stream.samples().len(), 10);
    stream.discard_before(Stamp::from_nanos(112_000_000));
    let first = stream.samples()[0].stamp;
    assert_eq!(first, Stamp::from_nanos(110_000_000));
}

#[test]
fn separate_gyro_and_accel_are_united_at_the_gyro_stamps() {
    let mut union = GyroAccelUnion::default();
    let mut out = Vec::new();
    // Accel at 0, 10, 20 ms reading 0, 1, 2; gyro at 2, 7, 13, 25 ms.
    union.push_accel(Stamp::from_nanos(0), Vector3::new(0.0, 0.0, 0.0), &mut out);
    union.push_gyro(Stamp::from_nanos(2_000_000), Vector3::x(), &mut out);
    union.push_gyro(Stamp::from_nanos(7_000_000), Vector3::y(), &mut out);
    assert!(
        out.is_empty(),
        "waits for the accelerometer to pass the gyro"
    );
    union.push_accel(
        Stamp::from_nanos(10_000_000),
        Vector3::new(1.0, 0.0, 0.0),
        &mut out,
    );
    union.push_gyro(Stamp::from_nanos(13_000_000), Vector3::z(), &mut out);
    union.push_accel(
        Stamp::from_nanos(20_000_000),
        Vector3::new(2.0, 0.0, 0.0),
        &mut out,
    );
    union.push_gyro(Stamp::from_nanos(25_000_000), Vector3::z(), &mut out);
    let got: Vec<(i64, f64)> = out
        .iter()
        .map(|s| (s.stamp.nanos() / 1_000_000, s.accel.x))
        .collect();
    assert_eq!(got.len(), 3, "{got:?}");
    for ((t, a), (t_expected, a_expected)) in got.iter().zip([(2, 0.2), (7, 0.7), (13, 1.3)]) {
        assert_eq!(*t, t_expected);
        assert!((a - a_expected).abs() < 1e-12, "{a} at {t} ms");
    }
    assert_eq!(out[1].gyro, Vector3::y());
}
