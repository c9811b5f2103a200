//! Rolling-shutter compensation: a rolling-shutter camera exposes its rows one after
//! the other, so under fast rotation the top and the bottom of a frame see the scene
//! from different orientations (a Kinect v1 turning at 90 deg/s skews its image by
//! tens of pixels), which no single pose explains. Each observation is re-timed to the
//! middle row by rotating its bearing with the motion model's angular velocity, so the
//! frame behaves as a global-shutter one. Translation during the readout is ignored:
//! at hand-held speeds it moves a pixel far less than rotation does.

use crate::frontend::features::FrameFeatures;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Point3, UnitQuaternion, Vector3};

/// Moves the keypoints, line endpoints and 3D lines of `features` to where the camera
/// would have seen them at the middle row's exposure. `angular_velocity` is the
/// camera's rotation rate (rad/s, rotation vector of `current_from_previous` per
/// second), `readout_s` the time from the first row to the last.
pub fn compensate(
    features: &mut FrameFeatures,
    camera: &PinholeCamera,
    angular_velocity: &Vector3<f64>,
    readout_s: f64,
) {
    if readout_s.is_nan() || readout_s <= 0.0 || !angular_velocity.iter().all(|w| w.is_finite()) {
        return;
    }
    let height = camera.height as f64;
    // A row read `t` seconds after the middle one sees with `camera(t) = exp(t w)
    // camera(0)`, so `exp(-t w)` turns its bearing into the middle row's.
    let to_middle = |v: f64| {
        let t = (v - camera.cy) / height * readout_s;
        UnitQuaternion::from_scaled_axis(-t * angular_velocity)
    };
    let move_pixel = |u: f32, v: f32| -> Option<(f32, f32)> {
        let n = camera.normalized(f64::from(u), f64::from(v));
        let bearing = to_middle(f64::from(v)) * Vector3::new(n.x, n.y, 1.0);
        let p = camera.project(&Point3::from(bearing))?;
        Some((p.x as f32, p.y as f32))
    };
    for kp in &mut features.keypoints {
        if let Some((u, v)) = move_pixel(kp.u, kp.v) {
            (kp.u, kp.v) = (u, v);
        }
    }
    for (line, line3) in features.lines.iter_mut().zip(&mut features.lines3d) {
        let [s, e] = [line.segment.start, line.segment.end];
        for (end, end3) in [(s, &mut line3.start), (e, &mut line3.end)] {
            let rotated = to_middle(f64::from(end[1]))
                * Vector3::new(f64::from(end3[0]), f64::from(end3[1]), f64::from(end3[2]));
            *end3 = [rotated.x as f32, rotated.y as f32, rotated.z as f32];
        }
        if let (Some(a), Some(b)) = (move_pixel(s[0], s[1]), move_pixel(e[0], e[1])) {
            line.segment.start = [a.0, a.1];
            line.segment.end = [b.0, b.1];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_lines::{DetectedLine, Line3, Segment};
    use gfs_points::KeyPoint;
    use nalgebra::Isometry3;

    /// Where a rolling-shutter camera turning at `w` (rad/s) about its middle-row
    /// orientation images `p` (camera frame at the middle row): the row's time depends
    /// on the row, so iterate to the fixed point.
    fn rolling_projection(
        camera: &PinholeCamera,
        w: &Vector3<f64>,
        readout: f64,
        p: &Point3<f64>,
    ) -> (f64, f64) {
        let mut uv = camera.project(p).expect("in front");
        for _ in 0..20 {
            let t = (uv.y - camera.cy) / camera.height as f64 * readout;
            let at_row =
                Isometry3::from_parts(Default::default(), UnitQuaternion::from_scaled_axis(t * w));
            uv = camera.project(&(at_row * p)).expect("in front");
        }
        (uv.x, uv.y)
    }

    #[test]
    fn a_rolling_shutter_frame_is_moved_to_the_middle_row_within_0_02_px() {
        let camera = PinholeCamera::new(517.0, 517.0, 318.6, 255.3, 640, 480);
        // 90 deg/s about a tilted axis, 20 ms readout: up to ~14 px of skew.
        let w = Vector3::new(0.3, 1.4, 0.5);
        let readout = 0.02;
        let points = [
            Point3::new(-0.8, -0.6, 2.0),
            Point3::new(0.7, 0.5, 1.5),
            Point3::new(0.1, -0.4, 3.0),
            Point3::new(-0.3, 0.6, 2.5),
        ];
        let mut features = FrameFeatures::default();
        let mut skew = 0f64;
        for p in &points {
            let (u, v) = rolling_projection(&camera, &w, readout, p);
            let global = camera.project(p).expect("in front");
            skew = skew.max((global.x - u).hypot(global.y - v));
            features.keypoints.push(KeyPoint {
                u: u as f32,
                v: v as f32,
                ..KeyPoint::default()
            });
        }
        let (s, e) = (points[0], points[1]);
        let (su, sv) = rolling_projection(&camera, &w, readout, &s);
        let (eu, ev) = (features.keypoints[1].u, features.keypoints[1].v);
        features.lines.push(DetectedLine {
            segment: Segment::new(su as f32, sv as f32, eu, ev),
            ..DetectedLine::default()
        });
        let to_row = |v: f64, p: &Point3<f64>| {
            let t = (v - camera.cy) / camera.height as f64 * readout;
            let q = UnitQuaternion::from_scaled_axis(t * w) * p.coords;
            [q.x as f32, q.y as f32, q.z as f32]
        };
        features.lines3d.push(Line3 {
            start: to_row(sv, &s),
            end: to_row(f64::from(ev), &e),
            ..Line3::default()
        });
        assert!(skew > 5.0, "the scenario must show the effect: {skew} px");

        compensate(&mut features, &camera, &w, readout);

        for (kp, p) in features.keypoints.iter().zip(&points) {
            let global = camera.project(p).expect("in front");
            let error = (f64::from(kp.u) - global.x).hypot(f64::from(kp.v) - global.y);
            assert!(error < 0.02, "{error} px");
        }
        let start = features.lines[0].segment.start;
        let global = camera.project(&s).expect("in front");
        assert!((f64::from(start[0]) - global.x).hypot(f64::from(start[1]) - global.y) < 0.02);
        let end3 = features.lines3d[0].end;
        let error = (Vector3::new(f64::from(end3[0]), f64::from(end3[1]), f64::from(end3[2]))
            - e.coords)
            .norm();
        assert!(error < 1e-4, "{error} m");
    }

    #[test]
    fn a_global_shutter_or_a_bad_rate_changes_nothing() {
        let camera = PinholeCamera::new(517.0, 517.0, 318.6, 255.3, 640, 480);
        let mut features = FrameFeatures::default();
        features.keypoints.push(KeyPoint {
            u: 100.0,
            v: 50.0,
            ..KeyPoint::default()
        });
        let w = Vector3::new(0.0, 2.0, 0.0);
        compensate(&mut features, &camera, &w, 0.0);
        compensate(&mut features, &camera, &w, f64::NAN);
        compensate(
            &mut features,
            &camera,
            &Vector3::new(f64::NAN, 0.0, 0.0),
            0.02,
        );
        assert_eq!(
            (features.keypoints[0].u, features.keypoints[0].v),
            (100.0, 50.0)
        );
    }
}
