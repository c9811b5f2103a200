//! Geometric exactness of noise-free renders: depth agrees across frames through the
//! ground-truth poses, every pixel lies on a ground-truth plane, and the ground-truth
//! edges land on strong image gradients.

use gfs_core::camera::PinholeCamera;
use gfs_synth::{NoiseConfig, SceneKind, SynthConfig, SynthFrame, SynthSequence, TrajectoryKind};
use nalgebra::Point3;

fn clean(
    scene: SceneKind,
    trajectory: TrajectoryKind,
    frames: usize,
    width: usize,
) -> SynthSequence {
    SynthSequence::new(SynthConfig {
        scene,
        trajectory,
        frames,
        noise: NoiseConfig::none(),
        camera: SynthConfig::scaled_camera(width),
        ..SynthConfig::default()
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Depth of `frame` at sub-pixel (`u`, `v`) by bilinear interpolation of inverse depth
/// (exact on a plane), or `None` near a depth discontinuity or a hole.
fn depth_at(frame: &SynthFrame, u: f64, v: f64) -> Option<f64> {
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (fx, fy) = (u - x0 as f64, v - y0 as f64);
    let z = |x, y| frame.depth.get(x, y).map(f64::from).filter(|&z| z > 0.0);
    let (a, b, c, d) = (
        z(x0, y0)?,
        z(x0 + 1, y0)?,
        z(x0, y0 + 1)?,
        z(x0 + 1, y0 + 1)?,
    );
    let (lo, hi) = (a.min(b).min(c).min(d), a.max(b).max(c).max(d));
    if hi / lo > 1.1 {
        return None;
    }
    let inv = (1.0 - fy) * ((1.0 - fx) / a + fx / b) + fy * ((1.0 - fx) / c + fx / d);
    Some(1.0 / inv)
}

#[test]
fn depth_of_frame_i_reprojects_onto_depth_of_frame_j() {
    for (scene, trajectory, i, j) in [
        (SceneKind::Room, TrajectoryKind::Slow, 0, 20),
        (SceneKind::Room, TrajectoryKind::Fast, 5, 12),
        (SceneKind::Corridor, TrajectoryKind::Rotation, 0, 15),
        (SceneKind::LowTexture, TrajectoryKind::Slow, 3, 25),
    ] {
        let seq = clean(scene, trajectory, 26, 160);
        let cam = seq.config().camera;
        let (fi, fj) = (seq.render(i), seq.render(j));
        let j_from_i = fj.pose.inverse() * fi.pose;
        let (mut errors, mut tried) = (Vec::new(), 0);
        for y in (0..cam.height).step_by(2) {
            for x in (0..cam.width).step_by(2) {
                let z = f64::from(fi.depth.get(x, y).unwrap());
                let p = j_from_i * cam.back_project(x as f64, y as f64, z);
                let Some(uv) = cam.project(&p) else { continue };
                if !cam.contains(uv.x, uv.y, 1.0) {
                    continue;
                }
                tried += 1;
                if let Some(zj) = depth_at(&fj, uv.x, uv.y) {
                    errors.push((zj - p.z).abs());
                }
            }
        }
        let compared = errors.len();
        let occluded = errors.iter().filter(|&&e| e > 0.05).count();
        let med = median(errors);
        println!(
            "{scene} {trajectory} {i}->{j}: {compared}/{tried} compared, median |dz| {:.4} mm, {occluded} occluded",
            med * 1e3
        );
        assert!(
            compared > tried / 2 && tried > 1000,
            "{scene} {i}->{j}: compared {compared} of {tried}"
        );
        assert!(med < 1e-3, "{scene} {i}->{j}: median |dz| = {med} m");
        assert!(
            occluded * 10 < compared,
            "{scene} {i}->{j}: {occluded} of {compared} off by > 5 cm"
        );
    }
}

#[test]
fn every_pixel_lies_on_a_ground_truth_plane() {
    for scene in SceneKind::ALL {
        let seq = clean(scene, TrajectoryKind::Fast, 40, 160);
        let planes = seq.scene().planes();
        let cam = seq.config().camera;
        for i in [0, 39] {
            let f = seq.render(i);
            let mut off = 0;
            for y in 0..cam.height {
                for x in 0..cam.width {
                    let z = f64::from(f.depth.get(x, y).unwrap());
                    assert!(
                        z > 0.1,
                        "{scene} frame {i} pixel ({x}, {y}): no depth in a closed scene"
                    );
                    let p = f.pose * cam.back_project(x as f64, y as f64, z);
                    let nearest = planes
                        .iter()
                        .map(|pl| (pl.normal.dot(&p.coords) - pl.offset).abs())
                        .fold(f64::INFINITY, f64::min);
                    off += usize::from(nearest > 1e-4 * z);
                }
            }
            assert_eq!(off, 0, "{scene} frame {i}: {off} pixels off every plane");
        }
    }
}

#[test]
fn walls_floor_and_ceiling_are_the_manhattan_axes_and_some_objects_are_rotated() {
    for scene in SceneKind::ALL {
        let s = gfs_synth::Scene::new(scene, 1);
        let planes = s.planes();
        let big: Vec<_> = planes.iter().filter(|p| p.area > 5.0).collect();
        assert_eq!(big.len(), 6, "{scene}: four walls, floor, ceiling");
        for p in &big {
            let on_axis = s
                .manhattan_axes()
                .iter()
                .any(|a| (a.dot(&p.normal).abs() - 1.0).abs() < 1e-12);
            assert!(on_axis, "{scene}: wall normal {:?}", p.normal);
        }
        let rotated = planes
            .iter()
            .filter(|p| p.normal.z.abs() < 1e-9 && p.normal.x.abs() > 0.1 && p.normal.y.abs() > 0.1)
            .count();
        // Four vertical faces per rotated box.
        assert!(rotated >= 4, "{scene}: {rotated} rotated vertical faces");
    }
}

/// Central-difference gradient magnitude of the gray image, gray levels per pixel.
fn gradient(f: &SynthFrame, x: usize, y: usize) -> f64 {
    let g = |x: usize, y: usize| f64::from(f.gray.get(x, y).unwrap());
    let gx = 0.5 * (g(x + 1, y) - g(x - 1, y));
    let gy = 0.5 * (g(x, y + 1) - g(x, y - 1));
    gx.hypot(gy)
}

/// Largest gradient in the 3x3 neighbourhood, if the edge point `p` is visible there.
fn edge_response(f: &SynthFrame, cam: &PinholeCamera, p: &Point3<f64>) -> Option<f64> {
    let p_in_camera = f.pose.inverse() * p;
    let uv = cam.project(&p_in_camera)?;
    if p_in_camera.z < 0.3 || !cam.contains(uv.x, uv.y, 3.0) {
        return None;
    }
    let (x, y) = (uv.x.round() as usize, uv.y.round() as usize);
    let mut visible = false;
    let mut best: f64 = 0.0;
    for yy in y - 1..=y + 1 {
        for xx in x - 1..=x + 1 {
            let z = f64::from(f.depth.get(xx, yy).unwrap());
            visible |= (z - p_in_camera.z).abs() < 0.02 + 0.01 * z;
            best = best.max(gradient(f, xx, yy));
        }
    }
    visible.then_some(best)
}

#[test]
fn scene_edges_project_onto_strong_gradients() {
    for (scene, frames) in [
        (SceneKind::Room, [0, 60]),
        (SceneKind::Corridor, [0, 60]),
        (SceneKind::LowTexture, [0, 60]),
    ] {
        let seq = clean(scene, TrajectoryKind::Fast, 61, 320);
        let cam = seq.config().camera;
        let (mut on_edges, mut anywhere) = (Vec::new(), Vec::new());
        for i in frames {
            let f = seq.render(i);
            for e in seq.scene().edges() {
                let n = ((e.b - e.a).norm() / 0.01).ceil() as usize;
                for k in 0..=n {
                    let p = e.a + (e.b - e.a) * (k as f64 / n as f64);
                    on_edges.extend(edge_response(&f, &cam, &p));
                }
            }
            for y in (5..cam.height - 5).step_by(7) {
                for x in (5..cam.width - 5).step_by(7) {
                    anywhere.push(gradient(&f, x, y));
                }
            }
        }
        let (samples, edge_med, base_med) = (on_edges.len(), median(on_edges), median(anywhere));
        println!(
            "{scene}: {samples} edge samples, median gradient {edge_med:.1} vs {base_med:.1} anywhere"
        );
        assert!(
            samples > 500,
            "{scene}: only {samples} visible edge samples"
        );
        assert!(
            edge_med > 8.0,
            "{scene}: median gradient on edges {edge_med}"
        );
        assert!(
            edge_med > 2.5 * base_med,
            "{scene}: edges {edge_med} vs anywhere {base_med}"
        );
    }
}

#[test]
fn render_view_is_the_noise_free_frame_of_the_sequence() {
    let seq = clean(SceneKind::Room, TrajectoryKind::Slow, 3, 160);
    let frame = seq.render(2);
    let (mut rgb, mut depth) = (
        gfs_core::RgbImage::new(0, 0),
        gfs_core::DepthImage::new(0, 0),
    );
    gfs_synth::render_view(
        seq.scene(),
        &seq.config().camera,
        &seq.pose(2),
        &mut rgb,
        &mut depth,
    );
    assert_eq!(rgb, frame.rgb);
    assert_eq!(depth, frame.depth);
}
