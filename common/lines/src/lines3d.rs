//! 3D lines from depth (section III-A, "Spatial Feature"): depth sampled along each
//! segment, depth-illegal samples dropped (missing, out of range, isolated spikes
//! across a discontinuity), samples back-projected and a 3D line fitted robustly
//! (RANSAC on sample pairs, then least squares on the inliers, twice), offset-illegal
//! samples dropped (farther from the line than the depth noise allows), and the 3D
//! endpoints placed on the rays of the 2D endpoints.
//!
//! Depth noise model: `sigma(z) = noise_coefficient * z^2` (Kinect-like, 1.425e-3 from
//! Khoshelham & Elberink 2012, the value PL-SLAM RGB-D systems use).

use crate::Segment;
use gfs_core::ImageView;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// A 3D segment in the camera frame (metres), from the 2D `start` to the 2D `end`.
/// Plain `#[repr(C)]` data (28 bytes, no padding) for zero-copy messages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[repr(C)]
pub struct Line3 {
    /// 3D point on the ray of the 2D start point, camera frame, metres.
    pub start: [f32; 3],
    /// 3D point on the ray of the 2D end point, camera frame, metres.
    pub end: [f32; 3],
    /// 1 when the line is valid (enough inliers covering enough of the segment), else 0
    /// and the endpoints are zero.
    pub valid: u32,
}

impl Line3 {
    /// True when the fit is usable.
    pub fn is_valid(&self) -> bool {
        self.valid != 0
    }
}

/// Parameters of the 3D line fit.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct Lines3dConfig {
    /// Distance between depth samples along the segment, pixels. Default 1.5.
    pub sample_step: f32,
    /// Nearest valid depth, metres. Default 0.1 (closer than any RGB-D sensor measures).
    pub min_depth: f32,
    /// Farthest valid depth, metres. Default 8.0 (Kinect-class noise beyond it is
    /// over 9 cm).
    pub max_depth: f32,
    /// Depth is also read this many pixels to both sides of the segment and the nearest
    /// valid value kept: a line on an occluding edge belongs to the foreground. Default
    /// 2.0 (0 reads only the pixel on the line).
    pub cross_offset: f32,
    /// A sample whose depth differs from both neighbours by more than this fraction of
    /// its depth lies across a discontinuity and is dropped. Default 0.05.
    pub jump_ratio: f32,
    /// Depth noise `sigma(z) = noise_coefficient * z^2`. Default 1.425e-3.
    pub noise_coefficient: f32,
    /// Inlier distance to the 3D line in noise sigmas. Default 3.0.
    pub inlier_sigmas: f32,
    /// Smallest inlier distance, metres (covers the 2D localisation error). Default 0.005.
    pub min_inlier_distance: f32,
    /// RANSAC iterations. Default 40.
    pub ransac_iterations: usize,
    /// Fewest inliers of a valid line. Default 8.
    pub min_inliers: usize,
    /// Smallest fraction of the depth-legal samples that must be inliers. Default 0.5.
    pub min_inlier_ratio: f32,
    /// Smallest fraction of the 2D segment spanned by the inliers. Default 0.5.
    pub min_coverage: f32,
}

impl Default for Lines3dConfig {
    fn default() -> Self {
        Self {
            sample_step: 1.5,
            min_depth: 0.1,
            max_depth: 8.0,
            cross_offset: 2.0,
            jump_ratio: 0.05,
            noise_coefficient: 1.425e-3,
            inlier_sigmas: 3.0,
            min_inlier_distance: 0.005,
            ransac_iterations: 40,
            min_inliers: 8,
            min_inlier_ratio: 0.5,
            min_coverage: 0.5,
        }
    }
}

/// One depth-legal sample: position along the segment (pixels), 3D point, threshold.
#[derive(Clone, Copy, Debug)]
struct Sample {
    t: f32,
    p: Vector3<f64>,
    threshold: f64,
}

/// Fits 3D lines; owns the per-line sample scratch.
#[derive(Clone, Debug)]
pub struct Line3Estimator {
    config: Lines3dConfig,
    depths: Vec<(f32, f32, f32, f32)>,
    samples: Vec<Sample>,
    inliers: Vec<bool>,
    rng: u64,
}

impl Line3Estimator {
    /// An estimator with `config`.
    pub fn new(config: Lines3dConfig) -> Self {
        Self {
            config,
            depths: Vec::new(),
            samples: Vec::new(),
            inliers: Vec::new(),
            rng: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Lines3dConfig {
        &self.config
    }

    /// Appends to `out` the 3D line of every segment, in order. `depth` is in metres
    /// (0 = missing), registered with the undistorted image of `camera`.
    pub fn estimate<'a, I>(
        &mut self,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
        segments: I,
        out: &mut Vec<Line3>,
    ) where
        I: IntoIterator<Item = &'a Segment>,
    {
        for s in segments {
            let line = self.estimate_one(depth, camera, s);
            out.push(line);
        }
    }

    /// The 3D line of one segment (invalid when the depth does not support one).
    pub fn estimate_one(
        &mut self,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
        segment: &Segment,
    ) -> Line3 {
        let invalid = Line3::default();
        let len = segment.length();
        // Longer than twice the image perimeter: not a segment of this image (and the
        // sample count must stay bounded).
        let longest = 4.0 * (depth.width() + depth.height()) as f32;
        if !(len.is_finite() && len >= 2.0 && len <= longest) || depth.is_empty() {
            return invalid;
        }
        self.sample_depths(depth, segment, len);
        self.back_project(camera);
        let c = self.config.clone();
        if self.samples.len() < c.min_inliers.max(2) {
            return invalid;
        }
        // Deterministic per segment, so results repeat run to run.
        self.rng =
            u64::from(segment.start[0].to_bits()) << 32 | u64::from(segment.end[1].to_bits());
        let Some((mut point, mut dir)) = self.ransac(len) else {
            return invalid;
        };
        // Least squares on the inliers, re-select (offset-illegal samples go), refit.
        for _ in 0..2 {
            self.mark_inliers(&point, &dir);
            match self.fit_inliers() {
                Some((p, d)) => (point, dir) = (p, d),
                None => return invalid,
            }
        }
        let count = self.mark_inliers(&point, &dir);
        let (mut t_min, mut t_max) = (f32::INFINITY, f32::NEG_INFINITY);
        for (s, _) in self.samples.iter().zip(&self.inliers).filter(|(_, i)| **i) {
            t_min = t_min.min(s.t);
            t_max = t_max.max(s.t);
        }
        // Without inliers the span is -inf: no coverage.
        let coverage = ((t_max - t_min) / len).max(0.0);
        if count < c.min_inliers
            || (count as f32) < c.min_inlier_ratio * self.samples.len() as f32
            || coverage < c.min_coverage
        {
            return invalid;
        }
        let ends = [segment.start, segment.end].map(|[u, v]| {
            let ray = Vector3::new(
                (f64::from(u) - camera.cx) / camera.fx,
                (f64::from(v) - camera.cy) / camera.fy,
                1.0,
            );
            closest_on_line_to_ray(&point, &dir, &ray)
        });
        match ends {
            [Some(a), Some(b)] if a.z > 0.0 && b.z > 0.0 => Line3 {
                start: [a.x as f32, a.y as f32, a.z as f32],
                end: [b.x as f32, b.y as f32, b.z as f32],
                valid: 1,
            },
            _ => invalid,
        }
    }

    /// Depth along the segment (nearest of the pixel and its two cross neighbours),
    /// keeping the depth-legal samples: in range, and not an isolated spike.
    fn sample_depths(&mut self, depth: &ImageView<'_, f32>, segment: &Segment, len: f32) {
        let c = &self.config;
        let step = c.sample_step.max(0.25);
        let (du, dv) = (
            (segment.end[0] - segment.start[0]) / len,
            (segment.end[1] - segment.start[1]) / len,
        );
        let (nu, nv) = (-dv * c.cross_offset, du * c.cross_offset);
        let read = |u: f32, v: f32| -> f32 {
            let (x, y) = (u.round(), v.round());
            if x < 0.0 || y < 0.0 {
                return 0.0;
            }
            match depth.get(x as usize, y as usize) {
                Some(z) if z.is_finite() && z >= c.min_depth && z <= c.max_depth => z,
                _ => 0.0,
            }
        };
        self.depths.clear();
        let n = (len / step).floor() as usize + 1;
        for i in 0..n {
            let t = i as f32 * step;
            let (u, v) = (segment.start[0] + t * du, segment.start[1] + t * dv);
            let mut z = read(u, v);
            if c.cross_offset > 0.0 {
                for candidate in [read(u + nu, v + nv), read(u - nu, v - nv)] {
                    if candidate > 0.0 && (z == 0.0 || candidate < z) {
                        z = candidate;
                    }
                }
            }
            if z > 0.0 {
                self.depths.push((t, u, v, z));
            }
        }
        // Isolated spikes: far from both neighbours (a sample across a discontinuity).
        let m = self.depths.len();
        let jump = c.jump_ratio;
        let mut keep = 0;
        for i in 0..m {
            let z = self.depths[i].3;
            let spike = i > 0
                && i + 1 < m
                && (z - self.depths[i - 1].3).abs() > jump * z
                && (z - self.depths[i + 1].3).abs() > jump * z;
            if !spike {
                self.depths[keep] = self.depths[i];
                keep += 1;
            }
        }
        self.depths.truncate(keep);
    }

    /// 3D points (camera frame) and inlier thresholds of the legal samples.
    fn back_project(&mut self, camera: &PinholeCamera) {
        let c = &self.config;
        self.samples.clear();
        for &(t, u, v, z) in &self.depths {
            let z64 = f64::from(z);
            let p = Vector3::new(
                (f64::from(u) - camera.cx) / camera.fx * z64,
                (f64::from(v) - camera.cy) / camera.fy * z64,
                z64,
            );
            let sigma = f64::from(c.noise_coefficient) * z64 * z64;
            let threshold =
                (f64::from(c.inlier_sigmas) * sigma).max(f64::from(c.min_inlier_distance));
            self.samples.push(Sample { t, p, threshold });
        }
    }

    /// RANSAC on pairs of samples at least a quarter of the segment apart; the line
    /// (point, unit direction) with the most inliers.
    fn ransac(&mut self, len: f32) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let n = self.samples.len();
        let mut best: Option<(usize, Vector3<f64>, Vector3<f64>)> = None;
        for _ in 0..self.config.ransac_iterations.max(1) {
            let i = (self.next_random() % n as u64) as usize;
            let j = (self.next_random() % n as u64) as usize;
            let (a, b) = (&self.samples[i], &self.samples[j]);
            if (a.t - b.t).abs() < 0.25 * len {
                continue;
            }
            let d = b.p - a.p;
            let norm = d.norm();
            if norm < 1e-9 {
                continue;
            }
            let dir = d / norm;
            let count = self
                .samples
                .iter()
                .filter(|s| distance(&s.p, &a.p, &dir) <= s.threshold)
                .count();
            if best.as_ref().is_none_or(|(c, _, _)| count > *c) {
                best = Some((count, a.p, dir));
                if count == n {
                    break;
                }
            }
        }
        best.map(|(_, p, d)| (p, d))
    }

    /// Marks the samples within their threshold of the line; returns how many.
    fn mark_inliers(&mut self, point: &Vector3<f64>, dir: &Vector3<f64>) -> usize {
        self.inliers.clear();
        self.inliers.extend(
            self.samples
                .iter()
                .map(|s| distance(&s.p, point, dir) <= s.threshold),
        );
        self.inliers.iter().filter(|i| **i).count()
    }

    /// Least-squares line of the inliers: centroid and principal axis of the scatter.
    fn fit_inliers(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let mut sum = Vector3::zeros();
        let mut n = 0.0;
        for (s, _) in self.samples.iter().zip(&self.inliers).filter(|(_, i)| **i) {
            sum += s.p;
            n += 1.0;
        }
        if n < 2.0 {
            return None;
        }
        let centroid = sum / n;
        let mut scatter = Matrix3::zeros();
        for (s, _) in self.samples.iter().zip(&self.inliers).filter(|(_, i)| **i) {
            let d = s.p - centroid;
            scatter += d * d.transpose();
        }
        let eigen = scatter.symmetric_eigen();
        let k = eigen.eigenvalues.imax();
        let dir = eigen.eigenvectors.column(k).into_owned();
        let norm = dir.norm();
        (norm > 0.5 && eigen.eigenvalues[k] > 0.0).then(|| (centroid, dir / norm))
    }

    /// splitmix64.
    fn next_random(&mut self) -> u64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// Distance of `p` to the line through `point` along the unit `dir`.
fn distance(p: &Vector3<f64>, point: &Vector3<f64>, dir: &Vector3<f64>) -> f64 {
    let d = p - point;
    (d - dir * d.dot(dir)).norm()
}

/// The point of the line `point + s dir` closest to the ray `t ray` (t > 0) through the
/// camera centre; `None` when the line runs (nearly) along the ray.
fn closest_on_line_to_ray(
    point: &Vector3<f64>,
    dir: &Vector3<f64>,
    ray: &Vector3<f64>,
) -> Option<Vector3<f64>> {
    let (a, b, c) = (dir.dot(dir), dir.dot(ray), ray.dot(ray));
    let (d, e) = (dir.dot(point), ray.dot(point));
    let denom = a * c - b * b;
    if denom <= 1e-6 * a * c {
        return None;
    }
    let s = (b * e - c * d) / denom;
    Some(point + dir * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::Rng;
    use gfs_core::Image;

    /// A room seen from 1 m above the floor (y down): floor y = 1, back wall z = 4,
    /// left wall x = -1.5, and a box face z = 2 over x in [-0.3, 0.5], y in [-0.2, 0.6].
    fn depth_along(ray: &Vector3<f64>) -> f64 {
        let mut best = f64::INFINITY;
        let mut hit = |t: f64, ok: bool| {
            if ok && t > 0.0 && t < best {
                best = t;
            }
        };
        let t = 1.0 / ray.y;
        hit(t, ray.y > 0.0);
        hit(4.0 / ray.z, true);
        let t = -1.5 / ray.x;
        hit(t, ray.x < 0.0);
        let t = 2.0 / ray.z;
        let (x, y) = (ray.x * t, ray.y * t);
        hit(t, (-0.3..=0.5).contains(&x) && (-0.2..=0.6).contains(&y));
        best * ray.z
    }

    fn camera() -> PinholeCamera {
        PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
    }

    /// Kinect-like depth: sigma 1.425e-3 z^2, 10 % random holes and a 60 x 40 px hole.
    fn render_depth(rng: &mut Rng) -> Image<f32> {
        let cam = camera();
        let mut depth = Image::new(640, 480);
        for v in 0..480 {
            for u in 0..640 {
                let ray = Vector3::new(
                    (u as f64 - cam.cx) / cam.fx,
                    (v as f64 - cam.cy) / cam.fy,
                    1.0,
                );
                let z = depth_along(&ray);
                let hole =
                    rng.uniform() < 0.1 || ((300..360).contains(&u) && (400..440).contains(&v));
                let noisy = z + 1.425e-3 * z * z * rng.gaussian();
                depth.set(
                    u,
                    v,
                    if hole || !z.is_finite() {
                        0.0
                    } else {
                        noisy as f32
                    },
                );
            }
        }
        depth
    }

    /// Ground-truth 3D segments: creases, texture lines on the planes, box edges.
    fn truth(rng: &mut Rng) -> Vec<(Vector3<f64>, Vector3<f64>)> {
        let v = Vector3::new;
        let mut lines = vec![
            (v(-1.4, 1.0, 4.0), v(1.9, 1.0, 4.0)), // floor / back wall crease
            (v(-1.5, -0.9, 4.0), v(-1.5, 0.95, 4.0)), // left / back wall crease
            (v(-1.5, 1.0, 3.8), v(-1.5, 1.0, 2.8)), // floor / left wall crease
            (v(-0.3, -0.2, 2.0), v(0.5, -0.2, 2.0)), // box edges (occluding)
            (v(0.5, -0.2, 2.0), v(0.5, 0.6, 2.0)),
            (v(-0.3, 0.6, 2.0), v(-0.3, -0.2, 2.0)),
        ];
        let cam = camera();
        let in_view = |p: &Vector3<f64>| {
            cam.project(&(*p).into())
                .is_some_and(|q| cam.contains(q.x, q.y, 5.0))
        };
        let mut k = 0;
        while lines.len() < 30 {
            k += 1;
            let r = |rng: &mut Rng, a: f64, b: f64| a + (b - a) * rng.uniform();
            let (a, b) = match k % 3 {
                // Back wall texture, avoiding the box's shadow region x in [-0.7, 1.0].
                0 => {
                    let x = if rng.uniform() < 0.5 {
                        r(rng, -1.4, -0.9)
                    } else {
                        r(rng, 1.2, 1.9)
                    };
                    (
                        v(x, r(rng, -0.9, 0.2), 4.0),
                        v(x + r(rng, -0.3, 0.3), r(rng, 0.3, 0.9), 4.0),
                    )
                }
                // Floor texture.
                1 => (
                    v(r(rng, -1.2, 1.2), 1.0, r(rng, 1.6, 2.2)),
                    v(r(rng, -1.2, 1.2), 1.0, r(rng, 2.6, 3.8)),
                ),
                // Left wall texture.
                _ => (
                    v(-1.5, r(rng, -0.5, 0.2), r(rng, 1.8, 2.5)),
                    v(-1.5, r(rng, 0.3, 0.9), r(rng, 3.0, 3.9)),
                ),
            };
            if in_view(&a) && in_view(&b) {
                lines.push((a, b));
            }
        }
        lines
    }

    fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        (a.dot(b).abs() / (a.norm() * b.norm()))
            .min(1.0)
            .acos()
            .to_degrees()
    }

    #[test]
    fn direction_error_on_noisy_planes_is_below_two_degrees() {
        let mut rng = Rng(11);
        let cam = camera();
        let depth = render_depth(&mut rng);
        let mut estimator = Line3Estimator::new(Lines3dConfig::default());
        let (mut errors, mut end_errors, mut invalid) = (Vec::new(), Vec::new(), 0);
        for (k, (a, b)) in truth(&mut rng).into_iter().enumerate() {
            let pa = cam.project(&a.into()).unwrap();
            let pb = cam.project(&b.into()).unwrap();
            // 2D endpoints as a detector gives them: up to 0.3 px off.
            let jitter = |rng: &mut Rng| (rng.uniform() as f32 - 0.5) * 0.6;
            let s = Segment::new(
                pa.x as f32 + jitter(&mut rng),
                pa.y as f32 + jitter(&mut rng),
                pb.x as f32 + jitter(&mut rng),
                pb.y as f32 + jitter(&mut rng),
            );
            let line = estimator.estimate_one(&depth.view(), &cam, &s);
            if !line.is_valid() {
                invalid += 1;
                continue;
            }
            let (s3, e3) = (
                Vector3::from(line.start).cast::<f64>(),
                Vector3::from(line.end).cast::<f64>(),
            );
            if (3..6).contains(&k) {
                // Occluding box edges take the foreground depth (2 m), not the wall's 4 m.
                let ok = (s3.z - 2.0).abs() < 0.05 && (e3.z - 2.0).abs() < 0.05;
                assert!(ok, "box edge {k}: {line:?}");
            }
            errors.push(angle_deg(&(e3 - s3), &(b - a)));
            end_errors.push((s3 - a).norm().max((e3 - b).norm()));
        }
        errors.sort_by(f64::total_cmp);
        end_errors.sort_by(f64::total_cmp);
        let median = errors[errors.len() / 2];
        let end_median = end_errors[end_errors.len() / 2];
        println!(
            "{} valid, {invalid} invalid; direction error median {median:.2} deg, max {:.2}; endpoint error median {:.3} m",
            errors.len(),
            errors[errors.len() - 1],
            end_median
        );
        assert!(invalid <= 3, "{invalid} of 30 lines invalid");
        assert!(median <= 2.0, "median direction error {median} deg");
        assert!(end_median <= 0.05, "median endpoint error {end_median} m");
    }

    #[test]
    fn lines_without_depth_support_are_invalid() {
        let cam = camera();
        let mut estimator = Line3Estimator::new(Lines3dConfig::default());
        let empty = Image::<f32>::new(640, 480);
        let s = Segment::new(100.0, 100.0, 300.0, 120.0);
        assert!(!estimator.estimate_one(&empty.view(), &cam, &s).is_valid());
        // Depth only on the first fifth of the segment: coverage too small.
        let mut partial = Image::<f32>::new(640, 480);
        for v in 0..480 {
            for u in 0..140 {
                partial.set(u, v, 2.0);
            }
        }
        assert!(!estimator.estimate_one(&partial.view(), &cam, &s).is_valid());
        // A constant-depth plane facing the camera gives a valid fronto-parallel line.
        partial.fill(2.0);
        let line = estimator.estimate_one(&partial.view(), &cam, &s);
        assert!(line.is_valid());
        assert!((line.start[2] - 2.0).abs() < 1e-3 && (line.end[2] - 2.0).abs() < 1e-3);
        let huge = Segment::new(-1e30, 0.0, 1e30, 5.0);
        assert!(
            !estimator
                .estimate_one(&partial.view(), &cam, &huge)
                .is_valid()
        );
        let tiny = Image::<f32>::new(0, 0);
        assert!(!estimator.estimate_one(&tiny.view(), &cam, &s).is_valid());
        let mut out = Vec::new();
        estimator.estimate(&partial.view(), &cam, &[Segment::default(), s], &mut out);
        assert_eq!(out.len(), 2);
        assert!(!out[0].is_valid() && out[1].is_valid());
    }
}
