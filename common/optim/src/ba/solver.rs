//! Local bundle adjustment (paper eq. 10-14): Levenberg-Marquardt over keyframe poses,
//! map points and map lines with reprojection, structural and Manhattan terms, in two
//! passes as ORB-SLAM2's local BA (a first pass, an outlier check, a second pass on the
//! inliers; the Huber kernel stays on in both).

use super::config::BaConfig;
use super::linear::ReducedSystem;
use super::normal::{Linearization, Step};
use super::problem::{BaError, BaProblem};
use super::terms::{BaFlags, Terms, Values};
use crate::lm::Damping;
use crate::residuals::plane_plus;
use gfs_core::se3::retract;

/// Relative cost decrease below which LM has converged.
const RELATIVE_COST_TOLERANCE: f64 = 1e-6;

/// Output of [`LocalBundleAdjuster::optimize`]; reuse one value to keep its buffers.
#[derive(Clone, Debug, Default)]
pub struct BaResult {
    /// Inlier flags of every term at the final estimate (chi-square test). The mapper
    /// erases the observations flagged `false` (ORB-SLAM2), and may drop the pairs and
    /// axis associations flagged `false`.
    pub inliers: BaFlags,
    /// Robust cost of the final inliers at the initial estimate (terms that cannot be
    /// evaluated there are skipped).
    pub initial_cost: f64,
    /// Robust cost of the final inliers at the final estimate.
    pub final_cost: f64,
    /// LM iterations over both passes.
    pub iterations: usize,
    /// Damped systems solved over both passes (iterations plus rejected steps).
    pub linear_solves: usize,
    /// True when the second pass converged before its iteration limit; false means the
    /// estimate is the last one reached (still written to the problem).
    pub converged: bool,
    /// True when the stop check ended the optimisation early: the estimate is the best
    /// iterate reached (LM only accepts steps that lower the cost) and the inlier flags
    /// were classified at it, as after a full run.
    pub interrupted: bool,
}

/// How one LM pass ended.
#[derive(Clone, Copy)]
struct Pass {
    iterations: usize,
    converged: bool,
    interrupted: bool,
}

impl Pass {
    fn ended(iterations: usize, converged: bool) -> Self {
        Self {
            iterations,
            converged,
            interrupted: false,
        }
    }
}

/// Reusable local BA: owns the linear-algebra scratch between calls.
///
/// Method (one LM step): linearise every active term; eliminate each point (3x3), each
/// plane outside every plane pair (3x3) and each line outside every parallel /
/// perpendicular pair (6x6) by the Schur complement; keep the paired lines and planes,
/// which the structural terms couple, in the reduced system with the free poses; solve
/// it with faer's sparse Cholesky (block AMD ordering, supernodal; the symbolic analysis
/// is kept while the pattern holds); back-substitute the eliminated landmarks. This is
/// the exact damped Gauss-Newton step. Passes: `first_pass_iterations`, chi-square
/// outlier check, `second_pass_iterations` on the inliers, final check (ORB-SLAM2 local
/// BA).
///
/// Cost: the point elimination is O(sum over points of observations^2) 6x6 blocks,
/// and the sparse factorisation grows with the pair graph: give each line a few
/// partners (the benchmark uses 2 + 2), not every other line.
#[derive(Default)]
pub struct LocalBundleAdjuster {
    values: Values,
    candidate: Values,
    initial: Values,
    linearization: Linearization,
    system: ReducedSystem,
    step: Step,
    solves: usize,
}

impl LocalBundleAdjuster {
    /// An adjuster with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Optimises the free poses, the points and the lines of `problem` in place.
    ///
    /// # Errors
    /// [`BaError`] when the problem refers to missing variables, holds non-finite
    /// values, fixes no pose, or the sparse solver cannot be set up; `problem` is then
    /// unchanged.
    pub fn optimize(
        &mut self,
        problem: &mut BaProblem,
        config: &BaConfig,
        result: &mut BaResult,
    ) -> Result<(), BaError> {
        self.optimize_until(problem, config, result, &|| false)
    }

    /// [`Self::optimize`], asking `stop` before every LM iteration: once it answers
    /// true, the iterations left (and the second pass) are skipped, the inliers are
    /// classified at the best iterate and that iterate is written to `problem`
    /// (ORB-SLAM2's local BA abort flag). The mapper stops this way when the next
    /// keyframe arrives or its time budget runs out.
    ///
    /// # Errors
    /// As [`Self::optimize`].
    pub fn optimize_until(
        &mut self,
        problem: &mut BaProblem,
        config: &BaConfig,
        result: &mut BaResult,
        stop: &dyn Fn() -> bool,
    ) -> Result<(), BaError> {
        problem.validate()?;
        self.solves = 0;
        self.values.copy_from_problem(problem);
        self.initial.clone_from(&self.values);
        self.linearization.resize(problem);
        {
            let terms = Terms::new(problem, config);
            let flags = &mut result.inliers;
            flags.reset(problem);
            terms.mark_invalid(&self.values, flags);
            let first = self.run_lm(&terms, flags, config.first_pass_iterations, config, stop)?;
            terms.classify(&self.values, flags);
            let second = if first.interrupted {
                Pass::ended(0, false)
            } else {
                self.run_lm(&terms, flags, config.second_pass_iterations, config, stop)?
            };
            terms.classify(&self.values, flags);
            result.iterations = first.iterations + second.iterations;
            result.interrupted = first.interrupted || second.interrupted;
            result.linear_solves = self.solves;
            result.converged = second.converged;
            result.initial_cost = terms.cost(&self.initial, flags, false).unwrap_or(0.0);
            result.final_cost = terms.cost(&self.values, flags, false).unwrap_or(0.0);
        }
        for (pose, value) in problem.poses.iter_mut().zip(&self.values.poses) {
            if !pose.fixed {
                pose.camera_from_world = *value;
            }
        }
        problem.points.clone_from(&self.values.points);
        problem.lines.clone_from(&self.values.lines);
        problem.planes.clone_from(&self.values.planes);
        Ok(())
    }

    /// One LM pass over the active terms, asking `stop` before each iteration.
    fn run_lm(
        &mut self,
        terms: &Terms<'_>,
        flags: &BaFlags,
        max_iterations: usize,
        config: &BaConfig,
        stop: &dyn Fn() -> bool,
    ) -> Result<Pass, BaError> {
        if max_iterations == 0 {
            return Ok(Pass::ended(0, false));
        }
        let problem = terms.problem;
        self.system.analyse(terms, flags)?;
        let mut damping = Damping::new();
        terms.linearize(&self.values, flags, &mut self.linearization);
        // Nothing to reduce (no active term, or an exact fit).
        if self.linearization.cost <= 0.0 {
            return Ok(Pass::ended(0, true));
        }
        for iteration in 1..=max_iterations {
            if stop() {
                return Ok(Pass {
                    iterations: iteration - 1,
                    converged: false,
                    interrupted: true,
                });
            }
            let mut accepted = None;
            loop {
                self.solves += 1;
                if let Ok(predicted) =
                    self.system
                        .solve(problem, &self.linearization, &damping, &mut self.step)
                {
                    self.apply_step(problem);
                    if let Some(cost) = terms.cost(&self.candidate, flags, true)
                        && cost < self.linearization.cost
                    {
                        let rho =
                            (self.linearization.cost - cost) / predicted.max(f64::MIN_POSITIVE);
                        damping.accept(rho);
                        accepted = Some(cost);
                        break;
                    }
                }
                if !damping.reject() {
                    break;
                }
            }
            // No decrease at any damping: a minimum to working precision.
            let Some(cost) = accepted else {
                return Ok(Pass::ended(iteration, true));
            };
            std::mem::swap(&mut self.values, &mut self.candidate);
            if self.linearization.cost - cost <= RELATIVE_COST_TOLERANCE * self.linearization.cost
                || self.poses_settled(problem, config)
            {
                return Ok(Pass::ended(iteration, true));
            }
            terms.linearize(&self.values, flags, &mut self.linearization);
        }
        Ok(Pass::ended(max_iterations, false))
    }

    /// True when the last step moved free poses, and none by `settled_step_m` /
    /// `settled_step_rad` or more.
    fn poses_settled(&self, problem: &BaProblem, config: &BaConfig) -> bool {
        let mut free = (self.step.pose.iter().zip(&problem.poses))
            .filter(|(_, pose)| !pose.fixed)
            .peekable();
        free.peek().is_some()
            && free.all(|(d, _)| {
                d.fixed_rows::<3>(0).norm() < config.settled_step_m
                    && d.fixed_rows::<3>(3).norm() < config.settled_step_rad
            })
    }

    /// `candidate = values ⊕ step` (left perturbation for poses, additive for points and
    /// lines, S2 x R for planes).
    fn apply_step(&mut self, problem: &BaProblem) {
        self.candidate.clone_from(&self.values);
        for ((c, d), pose) in self
            .candidate
            .poses
            .iter_mut()
            .zip(&self.step.pose)
            .zip(&problem.poses)
        {
            if !pose.fixed {
                *c = retract(c, d);
            }
        }
        for (c, d) in self.candidate.points.iter_mut().zip(&self.step.point) {
            *c += d;
        }
        for (c, d) in self.candidate.lines.iter_mut().zip(&self.step.line) {
            c[0] += d.fixed_rows::<3>(0);
            c[1] += d.fixed_rows::<3>(3);
        }
        for ((n, offset), d) in self.candidate.planes.iter_mut().zip(&self.step.plane) {
            (*n, *offset) = plane_plus(n, *offset, d);
        }
    }
}
