//! RANSAC over 3D-3D correspondences: keypoints back-projected with their measured depth
//! (camera frame) against map points (world frame). Three pairs give a rigid transform
//! (Kabsch); a hypothesis is scored by the reprojection error of every pair, so depth
//! noise does not decide what is an inlier.

use gfs_core::align::rigid_transform;
use gfs_core::camera::PinholeCamera;
use gfs_core::rng::SplitMix64;
use gfs_points::KeyPoint;
use nalgebra::{Isometry3, Point3, Vector2};

/// Reprojection error of an inlier, pixels.
const INLIER_PX: f64 = 4.0;

/// One keypoint with depth matched to a map point.
#[derive(Clone, Copy, Debug)]
pub struct Correspondence {
    /// The keypoint, undistorted pixels.
    pub uv: Vector2<f64>,
    /// The keypoint back-projected with its depth, camera frame.
    pub in_camera: Point3<f64>,
    /// The map point, world frame.
    pub in_world: Point3<f64>,
}

impl Correspondence {
    /// The pair of keypoint `kp` and a map point at `in_world`; `None` when the
    /// keypoint has no depth.
    pub fn new(camera: &PinholeCamera, kp: &KeyPoint, in_world: Point3<f64>) -> Option<Self> {
        let finite = kp.depth.is_finite() && in_world.coords.iter().all(|v| v.is_finite());
        if !finite || kp.depth <= 0.0 {
            return None;
        }
        let (u, v) = (f64::from(kp.u), f64::from(kp.v));
        Some(Self {
            uv: Vector2::new(u, v),
            in_camera: camera.back_project(u, v, f64::from(kp.depth)),
            in_world,
        })
    }
}

/// Reusable buffers of [`RigidRansac::solve`].
#[derive(Debug, Default)]
pub struct RigidRansac {
    src: Vec<Point3<f64>>,
    dst: Vec<Point3<f64>>,
    /// Inlier flag of each correspondence of the last solution.
    pub inliers: Vec<bool>,
}

impl RigidRansac {
    /// The `camera_from_world` most correspondences agree with (within 4 px), refined
    /// on its inliers, with the inlier count; `None` with fewer than 3 pairs or no valid
    /// hypothesis. `seed` makes the sampling reproducible; `inliers` holds the flags.
    pub fn solve(
        &mut self,
        pairs: &[Correspondence],
        camera: &PinholeCamera,
        iterations: usize,
        seed: u64,
    ) -> Option<(Isometry3<f64>, usize)> {
        self.inliers.clear();
        self.inliers.resize(pairs.len(), false);
        if pairs.len() < 3 {
            return None;
        }
        let mut rng = SplitMix64::new(seed);
        let mut best: Option<(usize, Isometry3<f64>)> = None;
        for _ in 0..iterations {
            self.src.clear();
            self.dst.clear();
            for _ in 0..3 {
                let k = rng.below(pairs.len() as u64) as usize;
                self.src.push(pairs[k].in_world);
                self.dst.push(pairs[k].in_camera);
            }
            let Some(hypothesis) = rigid_transform(&self.src, &self.dst) else {
                continue;
            };
            let count = count_inliers(pairs, camera, &hypothesis, None);
            if best.as_ref().is_none_or(|(n, _)| count > *n) {
                best = Some((count, hypothesis));
            }
        }
        let (_, hypothesis) = best?;
        count_inliers(pairs, camera, &hypothesis, Some(&mut self.inliers));
        self.src.clear();
        self.dst.clear();
        for (pair, inlier) in pairs.iter().zip(&self.inliers) {
            if *inlier {
                self.src.push(pair.in_world);
                self.dst.push(pair.in_camera);
            }
        }
        let refined = rigid_transform(&self.src, &self.dst)?;
        let count = count_inliers(pairs, camera, &refined, Some(&mut self.inliers));
        Some((refined, count))
    }
}

fn count_inliers(
    pairs: &[Correspondence],
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    mut flags: Option<&mut Vec<bool>>,
) -> usize {
    let mut count = 0;
    for (k, pair) in pairs.iter().enumerate() {
        let inlier = camera
            .project(&(camera_from_world * pair.in_world))
            .is_some_and(|uv| (uv.coords - pair.uv).norm() < INLIER_PX);
        if let Some(flags) = flags.as_deref_mut() {
            flags[k] = inlier;
        }
        count += usize::from(inlier);
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    #[test]
    fn recovers_the_pose_with_sixty_percent_outliers() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let truth = Isometry3::from_parts(
            Translation3::new(0.1, -0.05, 0.2),
            UnitQuaternion::from_euler_angles(0.05, -0.1, 0.2),
        );
        let mut rng = SplitMix64::new(3);
        let mut uniform = |lo: f64, hi: f64| rng.range(lo, hi);
        let mut pairs = Vec::new();
        for k in 0..100 {
            let in_camera = Point3::new(uniform(-1.0, 1.0), uniform(-0.8, 0.8), uniform(1.0, 4.0));
            let uv = camera.project(&in_camera).expect("in front").coords;
            let in_world = if k % 5 < 2 {
                truth.inverse() * in_camera
            } else {
                Point3::new(uniform(-2.0, 2.0), uniform(-2.0, 2.0), uniform(0.0, 4.0))
            };
            pairs.push(Correspondence {
                uv,
                in_camera,
                in_world,
            });
        }
        let mut ransac = RigidRansac::default();
        let (pose, inliers) = ransac.solve(&pairs, &camera, 300, 7).expect("a solution");
        assert_eq!(inliers, 40);
        let error = pose * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-9, "{error}");
        assert!(error.rotation.angle() < 1e-9);
        assert!(
            ransac
                .inliers
                .iter()
                .enumerate()
                .all(|(k, f)| *f == (k % 5 < 2))
        );
    }
}
