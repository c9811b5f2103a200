//! Timing and plane statistics on the TUM fr1 rpy sequence (skipped when the data is
//! absent). Prints figures, asserts only what does not depend on the machine.

use gfs_core::Image;
use gfs_core::camera::PinholeCamera;
use gfs_planes::{ManhattanEstimator, PlaneConfig, PlaneExtractor};
use std::path::PathBuf;
use std::time::Instant;

/// The sequence in the `shared` folder beside the repository.
fn dataset() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/tum_fr1_rpy_head300")
}
/// TUM depth PNG: 16-bit value / 5000 = metres.
const DEPTH_SCALE: f32 = 5000.0;

fn median_p90(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    (
        v[n / 2],
        v[((0.9 * n as f64).ceil() as usize).clamp(1, n) - 1],
    )
}

#[test]
fn tum_fr1_rpy_timings_and_planes() {
    let dir = dataset().join("depth");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!(
            "SKIPPED tum_fr1_rpy_timings_and_planes: {} is absent (needs ../shared/data beside the repository)",
            dir.display()
        );
        return;
    };
    let mut files: Vec<_> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
    files.sort();
    let depths: Vec<Image<f32>> = files
        .iter()
        .map(|f| {
            let png = image::open(f).unwrap().into_luma16();
            let data = png
                .pixels()
                .map(|p| f32::from(p.0[0]) / DEPTH_SCALE)
                .collect();
            Image::from_vec(png.width() as usize, png.height() as usize, data).unwrap()
        })
        .collect();
    let cam = PinholeCamera::new(517.3, 516.5, 318.6, 255.3, 640, 480);
    let config = PlaneConfig::default();
    let mut extractor = PlaneExtractor::new(&config).unwrap();
    let mut ma = ManhattanEstimator::new(&config).unwrap();
    let mut planes = Vec::new();
    let (mut normals_ms, mut bfs_ms, mut ma_ms, mut total_ms) = (vec![], vec![], vec![], vec![]);
    let (mut plane_count, mut with_ma, mut with_full_ma) = (0, 0, 0);
    for depth in &depths {
        let start = Instant::now();
        extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
        let before_ma = Instant::now();
        let axes = ma.estimate(&planes, &[], &[], None);
        let end = Instant::now();
        let t = extractor.timings();
        normals_ms.push(t.normals.as_secs_f64() * 1e3);
        bfs_ms.push(t.regions.as_secs_f64() * 1e3);
        ma_ms.push((end - before_ma).as_secs_f64() * 1e3);
        total_ms.push((end - start).as_secs_f64() * 1e3);
        plane_count += planes.len();
        with_ma += usize::from(axes.is_some());
        with_full_ma += usize::from(axes.is_some_and(|a| a.observed_count() >= 2));
    }
    let n = depths.len() as f64;
    for (name, v) in [
        ("normals", &mut normals_ms),
        ("bfs", &mut bfs_ms),
        ("ma", &mut ma_ms),
        ("total", &mut total_ms),
    ] {
        let (m, p) = median_p90(v);
        println!("{name}: median {m:.3} ms, p90 {p:.3} ms");
    }
    let mean_planes = plane_count as f64 / n;
    let ma_fraction = with_ma as f64 / n;
    println!(
        "{} frames: mean planes {mean_planes:.2}, MA in {:.1} % of frames, >= 2 observed axes in {:.1} %",
        depths.len(),
        100.0 * ma_fraction,
        100.0 * with_full_ma as f64 / n
    );
    // The rpy sequence looks at a desk and office walls throughout.
    assert!(mean_planes >= 1.0, "{mean_planes}");
    assert!(ma_fraction >= 0.5, "{ma_fraction}");
}
