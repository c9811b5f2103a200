//! Inputs that cannot hold a feature give an empty set or a clear error, never a panic.

use gfs_core::{GrayImage, Image, ImageView};
use gfs_points::{OrbConfig, OrbError, OrbExtractor, OrbFeatures, depth_at};

fn extract(orb: &mut OrbExtractor, image: &GrayImage) -> OrbFeatures {
    let mut f = OrbFeatures::default();
    orb.extract(image.view(), None, &mut f).unwrap();
    f
}

fn checkerboard(w: usize, h: usize) -> GrayImage {
    let data = (0..w * h)
        .map(|i| {
            if ((i % w) / 8 + (i / w) / 8).is_multiple_of(2) {
                30
            } else {
                220
            }
        })
        .collect();
    GrayImage::from_vec(w, h, data).unwrap()
}

#[test]
fn empty_tiny_and_flat_images_give_no_feature() {
    let mut orb = OrbExtractor::new(OrbConfig::default()).unwrap();
    for (w, h) in [
        (0, 0),
        (0, 480),
        (640, 0),
        (1, 1),
        (30, 30),
        (38, 200),
        (200, 38),
        (1, 5000),
    ] {
        let f = extract(&mut orb, &checkerboard(w, h));
        assert!(f.is_empty(), "{w}x{h}: {} features", f.len());
    }
    // Just big enough for one patch: features, all at least 19 px from the border.
    let f = extract(&mut orb, &checkerboard(39, 39));
    assert!(
        f.keypoints.iter().all(|k| k.u == 19.0 && k.v == 19.0),
        "{:?}",
        f.keypoints
    );
    for value in [0u8, 255, 128] {
        let flat = GrayImage::from_vec(640, 480, vec![value; 640 * 480]).unwrap();
        assert!(extract(&mut orb, &flat).is_empty(), "flat {value}");
    }
    // The extractor recovers after bad frames.
    assert!(extract(&mut orb, &checkerboard(640, 480)).len() > 100);
}

#[test]
fn strided_views_are_read_in_place() {
    // The same checkerboard inside a wider buffer gives the same features.
    let image = checkerboard(200, 150);
    let stride = 257;
    let mut buffer = vec![77u8; stride * 150];
    for y in 0..150 {
        buffer[y * stride..y * stride + 200].copy_from_slice(image.row(y));
    }
    let view = ImageView::new(200, 150, stride, &buffer).unwrap();
    let mut orb = OrbExtractor::new(OrbConfig::default()).unwrap();
    let mut a = OrbFeatures::default();
    let mut b = OrbFeatures::default();
    orb.extract(image.view(), None, &mut a).unwrap();
    orb.extract(view, None, &mut b).unwrap();
    assert!(!a.is_empty());
    assert_eq!(a, b);
}

#[test]
fn depth_is_validated_and_falls_back_to_a_neighbour() {
    let image = checkerboard(160, 120);
    let mut depth: Image<f32> = Image::new(160, 120);
    depth.fill(2.5);
    let mut orb = OrbExtractor::new(OrbConfig::default()).unwrap();
    let mut f = OrbFeatures::default();
    orb.extract(image.view(), Some(depth.view()), &mut f)
        .unwrap();
    assert!(!f.is_empty() && f.keypoints.iter().all(|k| k.depth == 2.5));

    // Missing centre: the nearest valid neighbour; none in range: 0.
    let mut d: Image<f32> = Image::new(5, 5);
    d.set(2, 3, 1.25);
    d.set(3, 3, 4.0);
    assert_eq!(depth_at(d.view(), 2.2, 1.8, 0.1, 10.0), 1.25);
    d.set(2, 3, f32::NAN);
    assert_eq!(depth_at(d.view(), 2.2, 1.8, 0.1, 10.0), 4.0);
    assert_eq!(depth_at(d.view(), 2.2, 1.8, 0.1, 3.0), 0.0);
    assert_eq!(depth_at(d.view(), 3.0, 3.0, 0.1, 10.0), 4.0);
    assert_eq!(depth_at(d.view(), -9.0, 3.0, 0.1, 10.0), 0.0);
    assert_eq!(depth_at(d.view(), f32::NAN, 3.0, 0.1, 10.0), 0.0);
    d.set(3, 3, f32::INFINITY);
    assert_eq!(depth_at(d.view(), 3.0, 3.0, 0.1, 10.0), 0.0);

    // A depth image of another size is an error that names both sizes.
    let small: Image<f32> = Image::new(80, 60);
    let err = orb
        .extract(image.view(), Some(small.view()), &mut f)
        .unwrap_err();
    assert_eq!(
        err,
        OrbError::DepthSize {
            width: 160,
            height: 120,
            depth_width: 80,
            depth_height: 60
        }
    );
    assert!(f.is_empty());
}

#[test]
fn invalid_configs_are_rejected() {
    for config in [
        OrbConfig {
            levels: 0,
            ..OrbConfig::default()
        },
        OrbConfig {
            features: 0,
            ..OrbConfig::default()
        },
        OrbConfig {
            scale_factor: f32::NAN,
            ..OrbConfig::default()
        },
        OrbConfig {
            cell_size: 2,
            ..OrbConfig::default()
        },
        OrbConfig {
            fast_min_threshold: 0,
            ..OrbConfig::default()
        },
    ] {
        assert!(OrbExtractor::new(config).is_err());
    }
}
