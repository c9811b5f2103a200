//! Levenberg-Marquardt over the 6x6 normal equations of one pose. It knows nothing of
//! the terms: a round hands it the linearisation and the cost of its current inliers,
//! so the same loop serves every mix of term kinds.

use crate::lm::Damping;
use crate::robust::Huber;
use gfs_core::se3::retract;
use nalgebra::{Isometry3, Matrix6, SMatrix, SVector, Vector6};

/// Relative cost decrease below which LM has converged: an accepted step's, or the
/// decrease the linearisation predicts for a candidate (a candidate that cannot beat
/// it is not evaluated).
const RELATIVE_COST_TOLERANCE: f64 = 1e-9;
/// Step norm below which LM has converged (metres / radians): a micrometre, a
/// microradian, far below any pose's uncertainty. Candidates as short are not
/// evaluated either: at the end of a run, where the cost's kinks (bilinear
/// interpolation, the robust kernels' bends, the refitted exposure gain) refuse the
/// step, the damping grew over some ten more evaluations of the cost to reach it
/// (low-texture slow seed 5 with all terms: 15722 cost evaluations of the photometric
/// term in 4348 iterations).
const STEP_TOLERANCE: f64 = 1e-6;

/// The normal equations of one linearisation: `H = sum J^T w Omega J` and
/// `g = sum J^T w Omega e` over the left perturbation `[rho; phi]`. The cost is not
/// summed here: LM judges steps by the cost function alone.
pub(super) struct Normal {
    pub(super) h: Matrix6<f64>,
    pub(super) g: Vector6<f64>,
}

impl Normal {
    pub(super) fn zeros() -> Self {
        Self {
            h: Matrix6::zeros(),
            g: Vector6::zeros(),
        }
    }

    /// Adds a residual with information `info`, robustified when `huber` is given;
    /// returns the weight it entered with (`info` times the kernel's weight).
    ///
    /// Always inlined: it is the inner loop of every block's linearisation, and the
    /// compiler leaves it a call from the point block, which made the optimiser
    /// measurably slower than with the update inlined into the loop.
    #[inline(always)]
    pub(super) fn add<const R: usize>(
        &mut self,
        j: &SMatrix<f64, R, 6>,
        e: &SVector<f64, R>,
        info: f64,
        huber: Option<&Huber>,
    ) -> f64 {
        let w = huber.map_or(1.0, |h| h.weight(info * e.norm_squared()));
        let jt_w = j.transpose() * (w * info);
        self.h += jt_w * j;
        self.g += jt_w * e;
        w * info
    }

    /// Adds `other`'s sums.
    pub(super) fn add_normal(&mut self, other: &Normal) {
        self.h += other.h;
        self.g += other.g;
    }
}

/// The outcome of one LM run.
pub(super) struct LmRun {
    /// The last accepted estimate.
    pub(super) pose: Isometry3<f64>,
    /// Iterations run.
    pub(super) iterations: usize,
    /// False when the iterations ran out before convergence.
    pub(super) converged: bool,
}

/// Minimises from `pose` in at most `max_iterations` steps. `linearize` gives the
/// normal equations at a pose, `cost` the cost there (`None` refuses the pose: a step
/// that pushes an inlier behind the camera).
pub(super) fn minimize(
    mut pose: Isometry3<f64>,
    max_iterations: usize,
    linearize: impl Fn(&Isometry3<f64>) -> Normal,
    cost: impl Fn(&Isometry3<f64>) -> Option<f64>,
) -> LmRun {
    let done = |pose, iterations, converged| LmRun {
        pose,
        iterations,
        converged,
    };
    let mut damping = Damping::new();
    let mut normal = linearize(&pose);
    // Steps are judged by `cost` alone. Judged against the linearisation's own sum,
    // which left out what has a cost but no gradient (photometric points off the image
    // or in the grid's border cells), candidates were refused at every damping while
    // the cost still fell (1398 times in one run of rotation seed 1, against 3603
    // accepted steps).
    let Some(mut current) = cost(&pose) else {
        return done(pose, 0, false);
    };
    // A stationary point (an exact fit): nothing to reduce.
    if normal.g == Vector6::zeros() {
        return done(pose, 0, true);
    }
    for iteration in 1..=max_iterations {
        let mut step = None;
        loop {
            let mut a = normal.h;
            let mut damping_diag = Vector6::zeros();
            for k in 0..6 {
                damping_diag[k] = damping.diagonal_term(normal.h[(k, k)]);
                a[(k, k)] += damping_diag[k];
            }
            if let Some(cholesky) = a.cholesky() {
                let delta = -cholesky.solve(&normal.g);
                // The decrease of the linearisation's cost along the damped step.
                let predicted =
                    delta.dot(&damping_diag.component_mul(&delta)) - normal.g.dot(&delta);
                if delta.norm() < STEP_TOLERANCE
                    || predicted <= RELATIVE_COST_TOLERANCE * current.abs()
                {
                    break;
                }
                let candidate = retract(&pose, &delta);
                if let Some(cost) = cost(&candidate)
                    && cost < current
                {
                    damping.accept((current - cost) / predicted);
                    step = Some((candidate, delta.norm(), cost));
                    break;
                }
            }
            if !damping.reject() {
                break;
            }
        }
        // No decrease at any damping, or none worth a step: the estimate is a minimum
        // to working precision.
        let Some((candidate, step_norm, cost)) = step else {
            return done(pose, iteration, true);
        };
        let decrease = current - cost;
        pose = candidate;
        // The cost may be negative: the depth pairs' average noise is taken out of it.
        if step_norm < STEP_TOLERANCE || decrease <= RELATIVE_COST_TOLERANCE * current.abs() {
            return done(pose, iteration, true);
        }
        current = cost;
        normal = linearize(&pose);
    }
    done(pose, max_iterations, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use std::cell::Cell;

    /// A run started at its cost's minimum whose linearisation points elsewhere (as the
    /// photometric term's central differences do beside a kink of the bilinear cost):
    /// returns the pose it ends at and how often it evaluated the cost.
    fn run_at_a_kinked_minimum(offset: f64) -> (Isometry3<f64>, usize) {
        let minimum = Isometry3::translation(0.2, -0.1, 1.0);
        let evaluations = Cell::new(0);
        let error = |pose: &Isometry3<f64>| gfs_core::se3::log(&(pose * minimum.inverse()));
        let run = minimize(
            minimum,
            10,
            |pose| Normal {
                h: Matrix6::identity(),
                g: error(pose) + Vector6::repeat(offset),
            },
            |pose| {
                evaluations.set(evaluations.get() + 1);
                Some(error(pose).norm_squared())
            },
        );
        assert!(run.converged);
        (run.pose, evaluations.get())
    }

    #[test]
    fn a_run_at_its_minimum_stops_once_no_step_worth_taking_is_left() {
        // The gradient's offset of 1e-4 predicts a decrease no step finds: the damping
        // grows until the steps are under a micrometre (before: until it was useless,
        // 11 evaluations).
        let (pose, evaluations) = run_at_a_kinked_minimum(1e-4);
        assert_eq!(pose.translation.vector, Vector3::new(0.2, -0.1, 1.0));
        assert!(evaluations <= 8, "{evaluations} evaluations");
        // Where the offset is below what a step of a micrometre could gain, not one
        // candidate is tried (before: 11 evaluations).
        let (_, evaluations) = run_at_a_kinked_minimum(1e-8);
        assert_eq!(evaluations, 1);
    }
}
