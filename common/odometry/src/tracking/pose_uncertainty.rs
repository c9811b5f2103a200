//! The covariance a tracked pose is published with: what the frame's measurements
//! determine (the motion prior left out: it is a prediction, not a measurement), plus
//! the frame-to-frame jitter of the poses that the measurement model does not explain,
//! estimated online from the poses themselves.
//!
//! The measurement model (independent keypoints of 1 px x 1.2^level, exact landmarks,
//! exact calibration and timing) holds for an ideal sensor only: on TUM fr1_rpy the
//! frame-to-frame error is 4-7 times the sigma it gives, along the rotation-translation
//! ambiguity of the view, and the residuals do not show it (a shift of the calibration,
//! of the rolling-shutter timing or of the landmarks moves the pose, not the residuals).
//! The poses do: a camera moves smoothly at the frame rate, so the second difference of
//! consecutive poses is the estimate's noise (plus the true acceleration, which only
//! makes the estimate cautious). For poses with independent errors of covariance `C`
//! and steps `dt1`, `dt2` (`r = dt2 / dt1`), the step's departure from the last step
//! scaled by `r` has the covariance `(1 + (1 + r)^2 + r^2) C`; its running means over
//! the last [`LONG_FRAMES`] and [`SHORT_FRAMES`] tracked frames give `C` for any
//! camera, without a parameter fitted to one sequence (adaptive estimation of a
//! filter's noise from its innovations, Mehra 1970). The published covariance is the
//! larger of the two models along every direction ([`larger_of`]).

use gfs_core::se3;
use nalgebra::{Isometry3, Matrix6, Vector6};

/// Tracked frames of the long average of the jitter (two seconds at 30 Hz): it holds
/// the level of a steady stretch.
pub const LONG_FRAMES: f64 = 60.0;

/// Tracked frames of the short average (a sixth of a second at 30 Hz): it follows a
/// burst (a fast turn, blur) within a few frames, which the long one would average
/// away; the two are added, so that a steady stretch is reported about twice as
/// cautiously and a burst is not missed (on TUM fr1_rpy the long average alone leaves
/// 9 % of the frame pairs beyond the 99.9 % bound).
pub const SHORT_FRAMES: f64 = 5.0;

/// A step longer than this many times the last one breaks the chain of poses (a frame
/// dropped or lost in between): its departure would be the motion over the gap.
const MAX_STEP_RATIO: f64 = 3.0;

/// Standard deviation reported along a direction the measurements leave free (metres;
/// rotations at the lever arm): the motion model placed the pose there, with an error
/// that grows without bound, and a consumer fusing the pose must not trust it.
pub const UNCONSTRAINED_SIGMA_M: f64 = 1.0;

/// An exponentially weighted mean of covariance samples over about `frames` samples.
#[derive(Clone, Debug, Default)]
struct RunningCovariance {
    sum: Matrix6<f64>,
    weight: f64,
}

impl RunningCovariance {
    fn added(&self, frames: f64, sample: &Matrix6<f64>) -> Self {
        let keep = 1.0 - 1.0 / frames;
        Self {
            sum: self.sum * keep + sample,
            weight: self.weight * keep + 1.0,
        }
    }

    fn mean(&self) -> Matrix6<f64> {
        if self.weight > 0.0 {
            self.sum / self.weight
        } else {
            Matrix6::zeros()
        }
    }
}

/// The jitter of the tracked poses, estimated from their second differences.
#[derive(Clone, Debug, Default)]
pub struct PoseJitter {
    /// The last two tracked poses (`camera_from_world`, timestamp), newest last.
    chain: Vec<(Isometry3<f64>, f64)>,
    long: RunningCovariance,
    short: RunningCovariance,
}

/// A gap or a step back in time before a pose: the chain starts again at it.
struct Gap;

impl PoseJitter {
    /// The covariance of the jitter with the sample of the frame at `camera_from_world`,
    /// `timestamp` counted in (its own departure is the best evidence of its error).
    pub fn covariance_with(
        &self,
        camera_from_world: &Isometry3<f64>,
        timestamp: f64,
    ) -> Matrix6<f64> {
        match self.sample(camera_from_world, timestamp) {
            Ok(Some(sample)) => {
                self.long.added(LONG_FRAMES, &sample).mean()
                    + self.short.added(SHORT_FRAMES, &sample).mean()
            }
            Ok(None) | Err(Gap) => self.learnt(),
        }
    }

    /// The covariance of the jitter learnt so far (zero before the first sample).
    fn learnt(&self) -> Matrix6<f64> {
        self.long.mean() + self.short.mean()
    }

    /// Adds a frame's final pose: tracked ones extend the chain (and give a sample once
    /// it holds two), others break it.
    pub fn observe(&mut self, camera_from_world: &Isometry3<f64>, timestamp: f64, tracked: bool) {
        if !tracked {
            self.chain.clear();
            return;
        }
        match self.sample(camera_from_world, timestamp) {
            Ok(Some(sample)) => {
                self.long = self.long.added(LONG_FRAMES, &sample);
                self.short = self.short.added(SHORT_FRAMES, &sample);
            }
            Ok(None) => {}
            Err(Gap) => self.chain.clear(),
        }
        if self.chain.len() == 2 {
            self.chain.remove(0);
        }
        self.chain.push((*camera_from_world, timestamp));
    }

    /// The departure of a pose from the straight continuation of the last two, scaled
    /// to one pose's covariance: with `x` the poses relative to the last one and
    /// `r = dt2 / dt1`, the departure `x_new + r x_older` of poses with independent
    /// errors of covariance `C` has the covariance `(1 + (1 + r)^2 + r^2) C`. Before
    /// anything is learnt, a pose after a single one gives its step as the departure
    /// (from standing still; two poses' errors): cautious while the camera moves.
    /// `None` with too few poses before it.
    fn sample(
        &self,
        camera_from_world: &Isometry3<f64>,
        timestamp: f64,
    ) -> Result<Option<Matrix6<f64>>, Gap> {
        match self.chain[..] {
            [(older, t0), (last, t1)] => {
                let (dt1, dt2) = (t1 - t0, timestamp - t1);
                if dt1 <= 0.0 || dt2 <= 0.0 || dt2 > MAX_STEP_RATIO * dt1 {
                    return Err(Gap);
                }
                let r = dt2 / dt1;
                let departure = se3::log(&(camera_from_world * last.inverse()))
                    + se3::log(&(older * last.inverse())) * r;
                Ok(Some(
                    departure * departure.transpose() / (1.0 + (1.0 + r).powi(2) + r * r),
                ))
            }
            [(last, t1)] if self.long.weight == 0.0 => {
                if timestamp <= t1 {
                    return Err(Gap);
                }
                let step = se3::log(&(camera_from_world * last.inverse()));
                Ok(Some(step * step.transpose() / 2.0))
            }
            _ => Ok(None),
        }
    }

    /// Starts the chain of poses afresh (a relocalised or restored frame), keeping what
    /// was learnt of the jitter.
    pub fn restart(&mut self) {
        self.chain.clear();
    }

    /// Re-expresses the chain in a corrected world (`new_from_old`).
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        for (pose, _) in &mut self.chain {
            *pose *= new_from_old.inverse();
        }
    }
}

/// The covariance that is at least `model` and at least `jitter` along every
/// direction: in `model`'s whitened axes (`model = L L^T`) the eigenvalues of
/// `L^-1 jitter L^-T` raised to 1. Each is a lower bound of the error: the model of
/// what the measurements' noise does, the jitter of what the poses show of it.
pub fn larger_of(model: &Matrix6<f64>, jitter: &Matrix6<f64>) -> Matrix6<f64> {
    let Some(cholesky) = model.cholesky() else {
        return model + jitter;
    };
    let l = cholesky.l();
    let Some(l_inv) = l.try_inverse() else {
        return model + jitter;
    };
    let whitened = l_inv * jitter * l_inv.transpose();
    l * gfs_optim::map_eigenvalues(&whitened, |e| e.max(1.0)) * l.transpose()
}

/// The covariance of a pose whose measurements gave it `information` (left perturbation
/// `[rho; phi]`), a direction they leave free reported at [`UNCONSTRAINED_SIGMA_M`]
/// (rotations weighed by `lever_arm_m`, as [`gfs_optim::analyse_constraint`]).
pub fn measurement_covariance(information: &Matrix6<f64>, lever_arm_m: f64) -> Matrix6<f64> {
    let inv_l = 1.0 / lever_arm_m.max(f64::MIN_POSITIVE);
    let s = Vector6::new(1.0, 1.0, 1.0, inv_l, inv_l, inv_l);
    let scaled = Matrix6::from_fn(|r, c| information[(r, c)] * s[r] * s[c]);
    let floor = 1.0 / (UNCONSTRAINED_SIGMA_M * UNCONSTRAINED_SIGMA_M);
    let scaled_covariance = gfs_optim::map_eigenvalues(&scaled, |l| {
        if l.is_finite() {
            1.0 / l.max(floor)
        } else {
            1.0 / floor
        }
    });
    Matrix6::from_fn(|r, c| scaled_covariance[(r, c)] * s[r] * s[c])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera turning and sliding at a constant rate, each pose off by noise of the
    /// standard deviations `sigma` (per component of `[rho; phi]`).
    fn noisy_run(sigma: &Vector6<f64>, frames: usize, seed: u64) -> PoseJitter {
        let mut rng = gfs_core::rng::SplitMix64::new(seed);
        let step = se3::exp(&Vector6::new(0.01, 0.002, -0.004, 0.01, -0.02, 0.005));
        let mut truth = Isometry3::identity();
        let mut jitter = PoseJitter::default();
        for k in 0..frames {
            let noise = Vector6::from_fn(|i, _| sigma[i] * rng.gaussian());
            jitter.observe(&(se3::exp(&noise) * truth), k as f64 / 30.0, true);
            truth = step * truth;
        }
        jitter
    }

    #[test]
    fn the_jitter_of_smooth_motion_is_the_poses_noise() {
        let sigma = Vector6::new(0.002, 0.001, 0.004, 0.003, 0.001, 0.002);
        // Averaged over independent runs: each long average holds ~60 samples.
        let runs = 40;
        let mut long = Matrix6::zeros();
        let mut both = Matrix6::zeros();
        for seed in 0..runs {
            let jitter = noisy_run(&sigma, 400, seed);
            long += jitter.long.mean() / runs as f64;
            both += jitter.learnt() / runs as f64;
        }
        for i in 0..6 {
            let ratio = long[(i, i)].sqrt() / sigma[i];
            assert!((0.9..1.1).contains(&ratio), "component {i}: {ratio}");
            // The long and the short average together: twice the variance.
            let ratio = both[(i, i)] / long[(i, i)];
            assert!((1.8..2.2).contains(&ratio), "component {i}: {ratio}");
        }
    }

    #[test]
    fn the_start_is_cautious_and_a_steady_motion_has_no_jitter() {
        // Without noise, the first step counts as jitter (from standing still) ...
        let start = noisy_run(&Vector6::zeros(), 2, 1).learnt();
        assert!(
            (start[(0, 0)] - 2.0 * 0.01f64.powi(2) / 2.0).abs() < 1e-12,
            "{start}"
        );
        // ... and fades: after 400 frames of steady motion, under 0.1 mm / 0.1 mrad.
        let steady = noisy_run(&Vector6::zeros(), 400, 1).learnt();
        for i in 0..6 {
            assert!(steady[(i, i)].sqrt() < 1e-4, "component {i}: {steady}");
        }
    }

    #[test]
    fn a_lost_frame_or_a_gap_breaks_the_chain_and_gives_no_sample() {
        let mut jitter = PoseJitter::default();
        let at = |x: f64| Isometry3::translation(x, 0.0, 0.0);
        jitter.observe(&at(0.0), 0.0, true);
        jitter.observe(&at(0.01), 1.0 / 30.0, true);
        let learnt = jitter.learnt();
        jitter.observe(&at(0.5), 2.0 / 30.0, false);
        jitter.observe(&at(0.03), 3.0 / 30.0, true);
        jitter.observe(&at(0.04), 4.0 / 30.0, true);
        // A second's gap: the motion over it is not a departure.
        jitter.observe(&at(0.9), 34.0 / 30.0, true);
        assert_eq!(jitter.learnt(), learnt);
        // Two poses later the chain gives a sample again: 1 cm of departure along x
        // over equal steps, a sixth of its square.
        jitter.observe(&at(0.91), 35.0 / 30.0, true);
        let Ok(Some(sample)) = jitter.sample(&at(0.93), 36.0 / 30.0) else {
            panic!("no sample");
        };
        assert!((sample[(0, 0)] - 1e-4 / 6.0).abs() < 1e-12, "{sample}");
        // A frame's own sample counts in its covariance.
        assert_ne!(jitter.covariance_with(&at(0.93), 36.0 / 30.0), learnt);
    }

    #[test]
    fn the_larger_of_model_and_jitter_holds_along_every_direction() {
        let model = Matrix6::identity() * 1e-6;
        let jitter = Matrix6::from_diagonal(&Vector6::new(4e-6, 0.25e-6, 0.0, 0.0, 0.0, 9e-6));
        let c = larger_of(&model, &jitter);
        let expected = Matrix6::from_diagonal(&Vector6::new(4e-6, 1e-6, 1e-6, 1e-6, 1e-6, 9e-6));
        assert!((c - expected).norm() < 1e-15, "{c}");
    }

    #[test]
    fn a_free_direction_is_reported_at_a_metre_and_a_determined_one_as_measured() {
        // Translation along x and rotation about z free, the rest held to 1 mm / 1 mrad.
        let information = Matrix6::from_diagonal(&Vector6::new(0.0, 1e6, 1e6, 1e6, 1e6, 0.0));
        let c = measurement_covariance(&information, 2.0);
        assert!((c[(0, 0)].sqrt() - 1.0).abs() < 1e-9, "{c}");
        // One metre at the 2 m lever arm: half a radian.
        assert!((c[(5, 5)].sqrt() - 0.5).abs() < 1e-9, "{c}");
        assert!((c[(1, 1)].sqrt() - 1e-3).abs() < 1e-12, "{c}");
        assert!((c[(3, 3)].sqrt() - 1e-3).abs() < 1e-12, "{c}");
    }
}
