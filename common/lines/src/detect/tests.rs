//! Behaviour of the detector and the joining on synthetic scenes with known segments.

use gfs_core::{Image, ImageView};

use super::test_scenes::{Canvas, Rng, coverage, endpoint_errors, on_truth, rectangle};
use super::{DetectConfig, LineDetector};
use crate::{DetectedLine, Segment};

fn detect_and_join(detector: &mut LineDetector, img: &Image<u8>) -> Vec<DetectedLine> {
    let mut lines = Vec::new();
    detector.detect(&img.view(), &mut lines);
    detector.join(&mut lines);
    lines
}

/// The sides of a polygon as ground-truth segments.
fn sides(poly: &[[f64; 2]]) -> Vec<Segment> {
    (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            Segment::new(a[0] as f32, a[1] as f32, b[0] as f32, b[1] as f32)
        })
        .collect()
}

/// A scene of non-overlapping rotated rectangles and triangles (sides >= 30 px) over a
/// smoothly shaded background, with gaussian noise of sigma 5; returns the image and the
/// ground-truth sides.
fn polygon_scene(seed: u64) -> (Image<u8>, Vec<Segment>) {
    let (w, h) = (320usize, 240usize);
    let mut rng = Rng::new(seed);
    let phase = rng.range(0.0, 6.0);
    let mut canvas = Canvas::new(w, h, |u, v| {
        110.0 + 15.0 * (u / 23.0 + phase).sin() * (v / 31.0).cos()
    });
    let mut placed: Vec<([f64; 2], f64)> = Vec::new();
    let mut truth = Vec::new();
    let mut attempts = 0;
    while placed.len() < 7 && attempts < 500 {
        attempts += 1;
        let (sw, sh) = (rng.range(32.0, 110.0), rng.range(32.0, 80.0));
        let radius = 0.5 * sw.hypot(sh);
        let c = [
            rng.range(radius + 4.0, w as f64 - radius - 4.0),
            rng.range(radius + 4.0, h as f64 - radius - 4.0),
        ];
        if !(c[0].is_finite() && c[1].is_finite())
            || placed
                .iter()
                .any(|(q, r)| (c[0] - q[0]).hypot(c[1] - q[1]) < radius + r + 6.0)
        {
            continue;
        }
        placed.push((c, radius));
        let angle = rng.range(0.0, std::f64::consts::PI);
        let value = if rng.uniform() < 0.5 {
            rng.range(20.0, 55.0)
        } else {
            rng.range(170.0, 240.0)
        };
        let poly: Vec<[f64; 2]> = if placed.len().is_multiple_of(3) {
            // A triangle with angles of at least ~45 degrees inside the same circle.
            let a0 = rng.range(0.0, std::f64::consts::TAU);
            [0.0, 2.2, 4.2]
                .iter()
                .map(|&k: &f64| {
                    [
                        c[0] + radius * (a0 + k).cos(),
                        c[1] + radius * (a0 + k).sin(),
                    ]
                })
                .collect()
        } else {
            rectangle(c, sw, sh, angle).to_vec()
        };
        canvas.fill_polygon(&poly, value);
        truth.extend(sides(&poly).into_iter().filter(|s| s.length() >= 30.0));
    }
    (canvas.to_gray(5.0, &mut rng), truth)
}

#[test]
fn polygon_sides_are_found_with_sub_pixel_endpoints() {
    let mut detector = LineDetector::new(DetectConfig::default());
    let (mut found, mut total) = (0usize, 0usize);
    let mut errors = Vec::new();
    for seed in 0..8 {
        let (img, truth) = polygon_scene(seed);
        let lines = detect_and_join(&mut detector, &img);
        for t in &truth {
            total += 1;
            if coverage(t, on_truth(t, &lines)) < 0.9 {
                continue;
            }
            found += 1;
            let best = on_truth(t, &lines)
                .max_by(|p, q| {
                    coverage(t, std::iter::once(*p)).total_cmp(&coverage(t, std::iter::once(*q)))
                })
                .expect("covered, so at least one piece");
            errors.extend(endpoint_errors(t, &best.segment));
        }
    }
    errors.sort_by(f32::total_cmp);
    let recall = found as f32 / total as f32;
    let median = errors[errors.len() / 2];
    println!("recall {found}/{total} = {recall:.3}, median endpoint error {median:.2} px");
    assert!(total >= 100, "{total} ground-truth sides");
    assert!(recall >= 0.95, "recall {recall}");
    assert!(median <= 1.0, "median endpoint error {median} px");
}

#[test]
fn pure_noise_gives_almost_no_lines() {
    let mut detector = LineDetector::new(DetectConfig::default());
    let mut rng = Rng::new(7);
    let mut counts = Vec::new();
    for sigma in [5.0, 10.0, 15.0, 20.0, 25.0, 30.0] {
        let canvas = Canvas::new(640, 480, |_, _| 128.0);
        let img = canvas.to_gray(sigma, &mut rng);
        counts.push(detect_and_join(&mut detector, &img).len());
    }
    println!("lines on noise (sigma 5..30): {counts:?}");
    assert!(counts.iter().sum::<usize>() <= counts.len(), "{counts:?}");
}

#[test]
fn gaps_up_to_five_pixels_are_bridged() {
    let mut detector = LineDetector::new(DetectConfig::default());
    let mut rng = Rng::new(3);
    for gap in 1..=5 {
        for angle_deg in [0.0f64, 17.0, 41.0, 98.0] {
            let angle = angle_deg.to_radians();
            let mut canvas = Canvas::new(320, 240, |_, _| 60.0);
            let (c, len) = ([160.0, 120.0], 200.0);
            let bar = rectangle(c, len, 60.0, angle);
            canvas.fill_polygon(&bar, 190.0);
            // Two thin occluders of mid grey cross the bar's top side (the side from
            // corner 0 to corner 1): the edge vanishes over `gap` px at each.
            let (s, co) = angle.sin_cos();
            for along in [-40.0, 35.0] {
                let centre = [c[0] + co * along + s * 30.0, c[1] + s * along - co * 30.0];
                canvas.fill_polygon(&rectangle(centre, gap as f64, 24.0, angle), 125.0);
            }
            let img = canvas.to_gray(5.0, &mut rng);
            let lines = detect_and_join(&mut detector, &img);
            let top = sides(&bar)[0];
            // Without joining the side is in pieces (smoothing bridges 1-2 px gaps).
            let mut unjoined = Vec::new();
            detector.detect(&img.view(), &mut unjoined);
            if gap >= 3 {
                let pieces = on_truth(&top, &unjoined).count();
                assert!(
                    pieces >= 3,
                    "gap {gap} px at {angle_deg} deg: {pieces} pieces"
                );
            }
            let pieces: Vec<&DetectedLine> = on_truth(&top, &lines).collect();
            let cover = coverage(&top, pieces.iter().copied());
            assert_eq!(
                pieces.len(),
                1,
                "gap {gap} px at {angle_deg} deg: {} pieces {pieces:?}",
                pieces.len()
            );
            assert!(
                cover >= 0.95,
                "gap {gap} px at {angle_deg} deg: coverage {cover}"
            );
        }
    }
}

#[test]
fn gaps_of_twenty_pixels_are_not_bridged() {
    let mut canvas = Canvas::new(320, 240, |_, _| 60.0);
    // Two collinear bright blocks 20 px apart: their top sides stay two segments.
    canvas.fill_polygon(&rectangle([90.0, 120.0], 100.0, 60.0, 0.2), 190.0);
    let c2 = [90.0 + 120.0 * 0.2f64.cos(), 120.0 + 120.0 * 0.2f64.sin()];
    canvas.fill_polygon(&rectangle(c2, 100.0, 60.0, 0.2), 190.0);
    let img = canvas.to_gray(5.0, &mut Rng::new(9));
    let lines = detect_and_join(&mut LineDetector::new(DetectConfig::default()), &img);
    let first = sides(&rectangle([90.0, 120.0], 100.0, 60.0, 0.2))[0];
    let pieces: Vec<_> = on_truth(&first, &lines).collect();
    assert_eq!(pieces.len(), 2, "{pieces:?}");
    assert!(
        pieces.iter().all(|p| p.segment.length() < 101.0),
        "{pieces:?}"
    );
}

#[test]
fn degenerate_images_give_no_lines_and_no_panic() {
    let mut detector = LineDetector::new(DetectConfig::default());
    let mut rng = Rng::new(11);
    let mut lines = Vec::new();
    for (w, h) in [(0, 0), (1, 1), (3, 3), (2, 50), (50, 2), (5, 5), (13, 9)] {
        let data: Vec<u8> = (0..w * h).map(|_| (rng.next_u64() & 0xff) as u8).collect();
        let img = Image::from_vec(w, h, data).unwrap();
        detector.detect(&img.view(), &mut lines);
        detector.join(&mut lines);
        assert!(lines.is_empty(), "{w}x{h}: {lines:?}");
        assert_eq!(detector.gradient_x().width(), w);
        assert_eq!(detector.gradient_y().height(), h);
    }
    for value in [0u8, 128, 255] {
        let img = Image::from_vec(640, 480, vec![value; 640 * 480]).unwrap();
        detector.detect(&img.view(), &mut lines);
        detector.join(&mut lines);
        assert!(lines.is_empty(), "constant {value}");
    }
    // A view with padding between rows reads only its own pixels.
    let mut padded = vec![255u8; 100 * 60];
    for (i, p) in padded.iter_mut().enumerate() {
        if i % 100 < 80 {
            *p = if (i % 100) < 40 { 20 } else { 220 };
        }
    }
    let view = ImageView::new(80, 60, 100, &padded).unwrap();
    detector.detect(&view, &mut lines);
    assert_eq!(lines.len(), 1, "{lines:?}");
    let s = lines[0].segment;
    assert!(
        (s.start[0] - 39.5).abs() < 0.3 && (s.end[0] - 39.5).abs() < 0.3,
        "{s:?}"
    );
    // Brighter to the right: the normal (dv, -du) / len must point to +u, so the
    // segment runs downwards (v increasing).
    assert!(s.end[1] > s.start[1], "{s:?}");
    // The exposed gradients: a step of 200 after smoothing, Sobel 8 x slope.
    let (gx, gy) = (detector.gradient_x(), detector.gradient_y());
    assert_eq!((gx.width(), gx.height()), (80, 60));
    assert!(gx.get(39, 30).unwrap() > 300 && gx.get(40, 30) == gx.get(39, 30));
    assert_eq!(gy.get(39, 30), Some(0));
    assert_eq!(gx.get(10, 30), Some(0));
}

#[test]
fn out_of_range_configs_do_not_panic() {
    let (img, _) = polygon_scene(3);
    let mut config = DetectConfig {
        gradient_threshold: 0,
        anchor_threshold: u16::MAX,
        scan_interval: 0,
        max_fit_error: f32::NAN,
        aligned_angle_deg: f32::INFINITY,
        max_nfa: f64::NAN,
        ..DetectConfig::default()
    };
    config.join.extension_gap = usize::MAX;
    config.join.merge_angle_deg = f32::NAN;
    config.join.merge_gap = f32::INFINITY;
    assert!(config.validate().is_err());
    let mut detector = LineDetector::new(config);
    let lines = detect_and_join(&mut detector, &img);
    assert!(lines.iter().all(|l| l.segment.length().is_finite()));
}

#[test]
fn segments_keep_the_bright_side_positive() {
    let mut canvas = Canvas::new(120, 120, |_, _| 40.0);
    canvas.fill_polygon(&rectangle([60.0, 60.0], 60.0, 44.0, 0.3), 200.0);
    let img = canvas.to_gray(5.0, &mut Rng::new(5));
    let mut detector = LineDetector::new(DetectConfig::default());
    let lines = detect_and_join(&mut detector, &img);
    assert_eq!(lines.len(), 4, "{lines:?}");
    for l in &lines {
        let [a, b, _] = l.segment.line_coefficients();
        let m = l.segment.midpoint();
        let at = |k: f32| {
            img.get(
                (m[0] + k * a).round() as usize,
                (m[1] + k * b).round() as usize,
            )
        };
        assert!(at(4.0) > at(-4.0), "{l:?}");
        assert!(l.mean_gradient > 100.0, "{l:?}");
    }
}

#[test]
fn reusing_the_detector_gives_the_same_lines() {
    let (a, _) = polygon_scene(100);
    let (b, _) = polygon_scene(101);
    let mut detector = LineDetector::new(DetectConfig::default());
    let first = detect_and_join(&mut detector, &a);
    detect_and_join(&mut detector, &b);
    let mut fresh = LineDetector::new(DetectConfig::default());
    assert_eq!(detect_and_join(&mut detector, &a), first);
    assert_eq!(detect_and_join(&mut fresh, &a), first);
}
