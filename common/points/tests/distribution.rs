//! Spatial distribution: features must reach every part of the image that has any
//! corner, not only the strongly textured parts.

mod common;

use common::Scene;
use gfs_core::GrayImage;
use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures, detect_fast};

const GRID_COLS: usize = 8;
const GRID_ROWS: usize = 6;

/// (cells of the 8x6 grid holding a FAST corner at the minimum threshold, how many of
/// those hold a feature, the features).
fn coverage(image: &GrayImage) -> (usize, usize, OrbFeatures) {
    let config = OrbConfig::default();
    let mut orb = OrbExtractor::new(config.clone()).unwrap();
    let mut features = OrbFeatures::default();
    orb.extract(image.view(), None, &mut features).unwrap();
    let (w, h) = (image.width() as f32, image.height() as f32);
    let cell_of = |u: f32, v: f32| {
        let cx = ((u / w * GRID_COLS as f32) as usize).min(GRID_COLS - 1);
        let cy = ((v / h * GRID_ROWS as f32) as usize).min(GRID_ROWS - 1);
        cy * GRID_COLS + cx
    };
    let mut corners = Vec::new();
    detect_fast(image.view(), config.fast_min_threshold, &mut corners);
    let mut has_corner = [false; GRID_COLS * GRID_ROWS];
    for c in &corners {
        has_corner[cell_of(c.x as f32, c.y as f32)] = true;
    }
    let mut has_feature = [false; GRID_COLS * GRID_ROWS];
    for k in &features.keypoints {
        has_feature[cell_of(k.u, k.v)] = true;
    }
    let wanted = has_corner.iter().filter(|&&c| c).count();
    let covered = has_corner
        .iter()
        .zip(&has_feature)
        .filter(|&(&c, &f)| c && f)
        .count();
    (wanted, covered, features)
}

#[test]
fn features_cover_weak_texture_beside_strong_texture() {
    // Left third: 600 high-contrast shapes. Rest: faint value noise and a few
    // low-contrast shapes, whose corners mostly pass only the minimum threshold.
    let mut scene = Scene::noise(640, 3, 6.0, 12);
    scene.add_shapes(11, 600, 0.0, 213.0, 1.0);
    scene.add_shapes(12, 250, 213.0, 640.0, 0.15);
    let image = scene.render(640, 480, |u, v| (u, v));
    let (wanted, covered, features) = coverage(&image);
    let weak = features.keypoints.iter().filter(|k| k.u >= 213.0).count();
    println!(
        "synthetic: {covered} of {wanted} cells with a corner hold a feature; \
         {weak} of {} features in the weak two thirds",
        features.len()
    );
    assert!(wanted >= 40, "{wanted}");
    assert!(covered * 10 >= wanted * 9, "{covered} / {wanted}");
    // The quadtree spreads the budget: the faint part gets a fair share.
    assert!(
        weak * 10 >= features.len() * 3,
        "{weak} / {}",
        features.len()
    );
}

#[test]
fn features_cover_a_real_frame() {
    // The sequence in the `shared` folder beside the repository.
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/tum_fr1_rpy_head300/rgb");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!(
            "SKIPPED features_cover_a_real_frame: {} is absent (needs ../shared/data beside the repository)",
            dir.display()
        );
        return;
    };
    let mut files: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    files.sort();
    for path in files.iter().step_by(100) {
        let rgb = image::open(path).unwrap().to_luma8();
        let (w, h) = rgb.dimensions();
        let image = GrayImage::from_vec(w as usize, h as usize, rgb.into_raw()).unwrap();
        let (wanted, covered, _) = coverage(&image);
        println!(
            "{}: {covered} of {wanted} cells with a corner hold a feature",
            path.display()
        );
        assert!(covered * 10 >= wanted * 9, "{covered} / {wanted}");
    }
}
