//! Reference intensities read in the frame's intensity grid, compared at the exposure
//! gain that fits the inliers best at each pose evaluated (closed form, see
//! [`crate::PhotometricTerm`]): the gain is recomputed in every cost, linearisation and
//! classification, never held from an earlier pose.

use super::{Block, Gate, flagged};
use crate::map_eigenvalues;
use crate::pose::correlation::TileScores;
use crate::pose::lm::Normal;
use crate::pose::{PhotometricObservation, PhotometricTerm, PoseOptimizerConfig};
use crate::residuals::{Photometric, PhotometricReading};
use crate::robust::Huber;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix6, Point3, Vector1, Vector6};

/// The photometric term, when any, with its kernel and threshold.
pub(crate) struct PhotometricBlock<'a> {
    camera: &'a PinholeCamera,
    term: Option<PhotometricTerm<'a>>,
    chi2: f64,
    huber: Huber,
}

impl<'a> PhotometricBlock<'a> {
    pub(crate) fn new(
        camera: &'a PinholeCamera,
        term: Option<PhotometricTerm<'a>>,
        config: &PoseOptimizerConfig,
    ) -> Self {
        Self {
            camera,
            term,
            chi2: config.photometric_chi2,
            huber: Huber::from_chi2(config.photometric_chi2),
        }
    }

    /// Reads the frame's grid for every observation flagged in `inliers` at `pose`
    /// (with the gradients when `with_gradient`) into `readings`, and returns the
    /// frame's gain over the reference there: least squares over the readings, 1
    /// without any. The errors are then taken from the same readings, one read each.
    fn read(
        &self,
        term: &PhotometricTerm<'_>,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        with_gradient: bool,
        readings: &mut Vec<Option<PhotometricReading>>,
    ) -> f64 {
        readings.clear();
        let (mut cross, mut square) = (0.0, 0.0);
        for obs in flagged(term.observations, inliers) {
            let reading = PhotometricReading::new(
                self.camera,
                &term.image,
                pose,
                &obs.point_in_world,
                with_gradient,
            );
            if let Some(r) = &reading {
                cross += obs.inv_sigma2 * r.value * obs.intensity;
                square += obs.inv_sigma2 * obs.intensity * obs.intensity;
            }
            readings.push(reading);
        }
        if square > 0.0 { cross / square } else { 1.0 }
    }

    /// The term's normal equations at `pose`, Huber-weighted when `robust`, each
    /// inlier's score added to `tiles` where it is read when given.
    fn own_normal(
        &self,
        term: &PhotometricTerm<'_>,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        mut tiles: Option<&mut TileScores<'_>>,
    ) -> Normal {
        let readings = &mut *term.scratch.readings.borrow_mut();
        let gain = self.read(term, pose, inliers, true, readings);
        let mut own = Normal::zeros();
        // sum w J_px^T J_px, and the weighted squared differences of the two gradients.
        let mut pixel_information = Matrix6::zeros();
        let (mut difference2, mut weight) = (0.0, 0.0);
        for (obs, reading) in flagged(term.observations, inliers).zip(readings.iter()) {
            let Some((r, l)) = reading
                .as_ref()
                .and_then(|r| Some((r, at_gain(obs, gain).linearize_reading(self.camera, r)?)))
            else {
                continue;
            };
            let w = own.add(
                &l.d_pose,
                &Vector1::new(l.error),
                obs.inv_sigma2,
                robust.then_some(&self.huber),
            );
            if let Some(tiles) = tiles.as_mut()
                && let Some(uv) = self.camera.project(&Point3::from(r.point_in_camera))
            {
                tiles.add(&uv, &(l.d_pose.transpose() * (w * l.error)));
            }
            pixel_information += l.d_pixel.transpose() * l.d_pixel * w;
            difference2 +=
                obs.inv_sigma2 * (l.gradient - obs.reference_gradient * gain).norm_squared();
            weight += obs.inv_sigma2;
        }
        // Each gradient component carries noise of variance sigma_g^2, which lends the
        // sums `sigma_g^2 sum w J_px^T J_px` of information the surface does not give (a
        // noisy gradient looks like texture, but the next frame's noise is another). The
        // frame's and the reference's gradients see the same surface with independent
        // noise: `E |g_c - gain g_r|^2 = 4 sigma_g^2`. A direction left with less than
        // none has none.
        if weight > 0.0 {
            own.h = map_eigenvalues(
                &(own.h - pixel_information * (difference2 / (4.0 * weight))),
                |l| l.max(0.0),
            );
        }
        own
    }
}

/// The reference intensity of `obs` in the frame's exposure.
fn at_gain(obs: &PhotometricObservation, gain: f64) -> Photometric {
    Photometric {
        intensity: gain * obs.intensity,
    }
}

impl Block for PhotometricBlock<'_> {
    fn num_observations(&self) -> usize {
        self.term.map_or(0, |t| t.observations.len())
    }

    inlier_fields!(photometric_inliers, num_photometric_inliers);

    fn cost(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, sum: f64) -> Option<f64> {
        let Some(term) = &self.term else {
            return Some(sum);
        };
        let readings = &mut *term.scratch.readings.borrow_mut();
        let gain = self.read(term, pose, inliers, false, readings);
        let (mut seen_cost, mut seen, mut total) = (0.0, 0usize, 0usize);
        for (obs, reading) in flagged(term.observations, inliers).zip(readings.iter()) {
            total += 1;
            if let Some(reading) = reading {
                let e = at_gain(obs, gain).error_of(reading);
                let s = obs.inv_sigma2 * e * e;
                seen_cost += if robust { self.huber.cost(s) } else { s };
                seen += 1;
            }
        }
        if total == 0 {
            return Some(sum);
        }
        // The points were paired in view of the pose the optimisation started from: a
        // pose that leaves at most half of them in view has escaped their cost rather
        // than fitted them, and is refused. Costed, the points out of view let a frame
        // whose start read them far off slide out of the image along a direction the
        // depth leaves free (unseen fast seed 13's second frame, tracked on depth
        // without a motion prior: 700 m away; the test below: 68 m).
        if 2 * seen <= total {
            return None;
        }
        // The points seen in the image, scaled to all the points: one that a step moves
        // off the image is unknown there, and any other cost pulls the pose. Costed at
        // the rejection threshold (about a hundred times a point's usual cost on a faint
        // wall), the points held the pose where they stayed in view (a wall turned 6
        // degrees from its reference was tracked 0.7 degrees past it); costed as
        // nothing, they would be pushed out. Scaled, a point costs the same in view or
        // out, on average.
        Some(sum + seen_cost * total as f64 / seen as f64)
    }

    fn linearize(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        normal: &mut Normal,
    ) {
        if let Some(term) = &self.term {
            normal.add_normal(&self.own_normal(term, pose, inliers, robust, None));
        }
    }

    fn correlated_excess(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        tile_px: f64,
        tile_scores: &mut Vec<Vector6<f64>>,
    ) -> Matrix6<f64> {
        let Some(term) = &self.term else {
            return Matrix6::zeros();
        };
        let mut tiles = TileScores::new(self.camera, tile_px, tile_scores);
        let own = self.own_normal(term, pose, inliers, false, Some(&mut tiles));
        tiles.excess(&own.h)
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        let Some(term) = &self.term else {
            return;
        };
        // The gain of the current inliers, before they are flagged again; their
        // readings serve again, the others are read here.
        let readings = &mut *term.scratch.readings.borrow_mut();
        let gain = self.read(term, pose, inliers, false, readings);
        let mut inlier_readings = readings.iter();
        let threshold = gate.threshold(self.chi2);
        for (flag, obs) in inliers.iter_mut().zip(term.observations) {
            let reading = if *flag {
                inlier_readings.next().copied().flatten()
            } else {
                PhotometricReading::new(self.camera, &term.image, pose, &obs.point_in_world, false)
            };
            *flag = obs.inv_sigma2 > 0.0
                && reading.is_some_and(|r| {
                    let e = at_gain(obs, gain).error_of(&r);
                    obs.inv_sigma2 * e * e <= threshold
                });
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::pose::{
        DepthObservation, PhotometricObservation, PhotometricScratch, PhotometricTerm,
        PoseOptimizerConfig, PoseResult, SurfaceObservations, optimize_pose_with_depth,
    };
    use crate::residuals::testing::{SplitMix64, vga_camera};
    use crate::residuals::{IntensityGrid, PosePrior};
    use nalgebra::{Isometry3, Matrix6, Vector3};

    const CELL_PX: u32 = 4;
    const WALL_M: f64 = 2.0;

    /// Faint stripes of `amplitude` gray levels across x on a wall at `WALL_M`, and
    /// across y too with `stripes_across_y`, seen from `camera_x` metres along x, as 4 px
    /// cell means with independent noise of `sigma` gray levels per cell.
    fn wall_cells(
        camera_x: f64,
        amplitude: f64,
        stripes_across_y: bool,
        sigma: f64,
        seed: u64,
    ) -> Vec<f32> {
        let (camera, mut rng) = (vga_camera(), SplitMix64::new(seed));
        let stripes = |t: f64| amplitude * (t * std::f64::consts::TAU / 0.5).sin();
        let (w, h) = (640 / CELL_PX as usize, 480 / CELL_PX as usize);
        let mut values = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let (u, v) = (i * CELL_PX as usize, j * CELL_PX as usize);
                let on_wall = camera.back_project(u as f64 + 1.5, v as f64 + 1.5, WALL_M);
                let paint = stripes(on_wall.x + camera_x)
                    + if stripes_across_y {
                        stripes(on_wall.y)
                    } else {
                        0.0
                    };
                // Twelve uniforms less six: near-gaussian, unit variance.
                let noise = (0..12).map(|_| rng.uniform(0.0, 1.0)).sum::<f64>() - 6.0;
                values.push((128.0 + paint + sigma * noise) as f32);
            }
        }
        values
    }

    fn grid(values: &[f32]) -> IntensityGrid<'_> {
        IntensityGrid {
            stride_px: CELL_PX,
            width: 640 / CELL_PX as usize,
            height: 480 / CELL_PX as usize,
            values,
        }
    }

    /// The wall's point at every cell of `reference` (seen from the identity) with its
    /// intensity and gradient there.
    fn wall_points(reference: &IntensityGrid<'_>) -> Vec<PhotometricObservation> {
        let camera = vga_camera();
        let mut photometric = Vec::new();
        for j in 1..118 {
            for i in 1..158 {
                let (u, v) = ((i * CELL_PX) as f64 + 1.5, (j * CELL_PX) as f64 + 1.5);
                let (intensity, gradient) = reference.intensity_and_gradient(u, v).expect("inside");
                photometric.push(PhotometricObservation {
                    point_in_world: camera.back_project(u, v, WALL_M).coords,
                    intensity,
                    reference_gradient: gradient,
                    // The two cells' noise, as for the noisy wall.
                    inv_sigma2: 1.0 / (2.0 * 0.3f64.powi(2)),
                });
            }
        }
        photometric
    }

    /// The wall's depth, which fixes the distance and the two tilts.
    fn wall_depth() -> Vec<DepthObservation> {
        (0..100)
            .map(|k| {
                let s = Vector3::new(
                    -1.0 + 0.2 * (k % 10) as f64,
                    -0.7 + 0.15 * (k / 10) as f64,
                    WALL_M,
                );
                DepthObservation {
                    point_in_camera: s,
                    surface_in_world: s,
                    normal_in_world: Vector3::new(0.0, 0.0, -1.0),
                    inv_sigma2: 1e6,
                    normal_tilt_variance: 0.0,
                }
            })
            .collect()
    }

    /// The pose from the identity, the wall's points seen in `frame_values`.
    fn align(
        reference_values: &[f32],
        frame_values: &[f32],
        prior: Option<PosePrior>,
    ) -> PoseResult {
        let photometric = wall_points(&grid(reference_values));
        let mut result = PoseResult::default();
        optimize_pose_with_depth(
            &vga_camera(),
            &Isometry3::identity(),
            &[],
            &[],
            SurfaceObservations {
                depth: &wall_depth(),
                photometric: Some(PhotometricTerm {
                    image: grid(frame_values),
                    observations: &photometric,
                    scratch: &PhotometricScratch::default(),
                }),
                prior,
                ..SurfaceObservations::default()
            },
            &PoseOptimizerConfig::default(),
            &mut result,
        );
        result
    }

    /// The information of the pose at the identity from the stripes across x, noise
    /// `sigma`, and the wall's depth, as if the cells' errors were independent (the
    /// excess their draw over the image's tiles shows put back).
    fn information(sigma: f64) -> Matrix6<f64> {
        let prior = PosePrior::isotropic(Isometry3::identity(), 0.01, 0.01);
        let result = align(
            &wall_cells(0.0, 2.0, false, sigma, 1),
            &wall_cells(0.0, 2.0, false, sigma, 2),
            Some(prior),
        );
        result.information + result.correlated_excess
    }

    #[test]
    fn points_moved_off_the_image_do_not_hold_the_pose_back() {
        // The frame is 5 cm along a faint wall (13 px at 2 m): on the way there, the
        // points of the image's first three cell columns move off it. Costed as
        // outliers, they held the pose 36 mm short.
        let result = align(
            &wall_cells(0.0, 0.2, true, 0.0, 1),
            &wall_cells(0.05, 0.2, true, 0.0, 2),
            None,
        );
        let t = result.camera_from_world.translation.vector;
        let error_mm = (t - Vector3::new(-0.05, 0.0, 0.0)).norm() * 1e3;
        assert!(error_mm < 0.3, "{error_mm} mm off: {t}");
        let angle_deg = result.camera_from_world.rotation.angle().to_degrees();
        assert!(angle_deg < 0.01, "{angle_deg} degrees");
    }

    #[test]
    fn a_frame_half_a_period_off_does_not_slide_out_of_the_image() {
        // Paint of 0.5 m period across x and y, the frame 0.25 m along x: at the start
        // every point reads the opposite stripe across x. Costed as points out of view, the points
        // gave way to a slide of 68 m and a turn of 47 degrees that took them all out of
        // the image; refused, the pose stays within their reach (here by its start: the
        // opposite stripes pull it neither way along x).
        let result = align(
            &wall_cells(0.0, 2.0, true, 0.3, 1),
            &wall_cells(0.25, 2.0, true, 0.3, 2),
            None,
        );
        let t = result.camera_from_world.translation.vector;
        assert!(t.norm() < 0.05, "{} m: {t}", t.norm());
        let angle_deg = result.camera_from_world.rotation.angle().to_degrees();
        assert!(angle_deg < 1.0, "{angle_deg} degrees");
    }

    #[test]
    fn the_noise_of_the_gradients_lends_no_information() {
        // Stripes across x fix the slide along x and nothing along y.
        let clean = information(0.0);
        assert!(clean[(1, 1)] < 1e-6 * clean[(0, 0)], "{clean}");
        // 0.3 gray levels of noise per cell give each gradient component a variance of
        // 2 0.3^2 / (2 * 4 px)^2 = 0.0028 (gray/px)^2, 0.6 of the stripes' mean square
        // slope (2 gray levels over 131 px periods): taken as texture, it would add 60 %
        // to the x information and as much along y.
        let noisy = information(0.3);
        let x_ratio = noisy[(0, 0)] / clean[(0, 0)];
        assert!((0.8..1.2).contains(&x_ratio), "x: {x_ratio}");
        assert!(
            noisy[(1, 1)] < 0.1 * clean[(0, 0)],
            "y: {}",
            noisy[(1, 1)] / clean[(0, 0)]
        );
    }
}
