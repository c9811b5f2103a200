//! Reference intensities read in the frame's intensity grid, compared at the exposure
//! gain that fits the inliers best at each pose evaluated (closed form, see
//! [`crate::PhotometricTerm`]): the gain is recomputed in every cost, linearisation and
//! classification, never held from an earlier pose.

use super::{Block, Gate, flagged};
use crate::pose::lm::Normal;
use crate::pose::{PhotometricObservation, PhotometricTerm, PoseOptimizerConfig};
use crate::residuals::Photometric;
use crate::robust::Huber;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Point3, Vector1};

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

    /// Whitened squared error at `gain`; `None` behind the camera or off the image.
    fn residual2(
        &self,
        term: &PhotometricTerm<'_>,
        pose: &Isometry3<f64>,
        obs: &PhotometricObservation,
        gain: f64,
    ) -> Option<f64> {
        let e = Photometric {
            intensity: gain * obs.intensity,
        }
        .error(self.camera, &term.image, pose, &obs.point_in_world)?;
        Some(obs.inv_sigma2 * e * e)
    }

    /// The frame's gain over the reference at `pose`, least squares over the
    /// observations flagged in `inliers` that project into the image; 1 without any.
    fn gain(&self, term: &PhotometricTerm<'_>, pose: &Isometry3<f64>, inliers: &[bool]) -> f64 {
        let (mut cross, mut square) = (0.0, 0.0);
        for obs in flagged(term.observations, inliers) {
            let p_c = pose * Point3::from(obs.point_in_world);
            if let Some(value) = self
                .camera
                .project(&p_c)
                .and_then(|uv| term.image.intensity(uv.x, uv.y))
            {
                cross += obs.inv_sigma2 * value * obs.intensity;
                square += obs.inv_sigma2 * obs.intensity * obs.intensity;
            }
        }
        if square > 0.0 { cross / square } else { 1.0 }
    }
}

impl Block for PhotometricBlock<'_> {
    fn num_observations(&self) -> usize {
        self.term.map_or(0, |t| t.observations.len())
    }

    inlier_fields!(photometric_inliers, num_photometric_inliers);

    fn cost(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        mut sum: f64,
    ) -> Option<f64> {
        let Some(term) = &self.term else {
            return Some(sum);
        };
        let gain = self.gain(term, pose, inliers);
        for obs in flagged(term.observations, inliers) {
            // A point moved off the image costs as one at the rejection threshold: a
            // step is not refused for a border point.
            let s = self
                .residual2(term, pose, obs, gain)
                .unwrap_or(self.huber.delta.powi(2));
            sum += if robust { self.huber.cost(s) } else { s };
        }
        Some(sum)
    }

    fn linearize(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        normal: &mut Normal,
    ) {
        let Some(term) = &self.term else {
            return;
        };
        let gain = self.gain(term, pose, inliers);
        for obs in flagged(term.observations, inliers) {
            let r = Photometric {
                intensity: gain * obs.intensity,
            };
            if let Some(l) = r.linearize(self.camera, &term.image, pose, &obs.point_in_world) {
                normal.add(
                    &l.d_pose,
                    &Vector1::new(l.error),
                    obs.inv_sigma2,
                    robust.then_some(&self.huber),
                );
            }
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        let Some(term) = &self.term else {
            return;
        };
        // The gain of the current inliers, before they are flagged again.
        let gain = self.gain(term, pose, inliers);
        let threshold = gate.threshold(self.chi2);
        for (flag, obs) in inliers.iter_mut().zip(term.observations) {
            *flag = obs.inv_sigma2 > 0.0
                && self
                    .residual2(term, pose, obs, gain)
                    .is_some_and(|s| s <= threshold);
        }
    }
}
