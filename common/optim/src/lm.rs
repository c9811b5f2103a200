//! Levenberg-Marquardt damping shared by the pose optimiser and local BA.
//!
//! The damped system is `(H + lambda D) delta = -g` with `D = diag(H)` clamped below
//! (Marquardt scaling, as Ceres), and `lambda` follows Nielsen's rule (as g2o): on an
//! accepted step `lambda *= max(1/3, 1 - (2 rho - 1)^3)`, on a rejected one
//! `lambda *= nu, nu *= 2`, where `rho` is the ratio of actual to predicted decrease.

/// Initial `lambda` (relative to the diagonal): close to Gauss-Newton from the start,
/// as the odometry always starts near the optimum.
const INITIAL_LAMBDA: f64 = 1e-4;
/// Smallest `lambda`, keeps the endpoint-sliding null space of lines regular.
const MIN_LAMBDA: f64 = 1e-10;
/// Largest `lambda`; beyond this the step is zero for all practical purposes.
pub(crate) const MAX_LAMBDA: f64 = 1e12;
/// Lower clamp of the diagonal scaling `D` (Ceres `min_lm_diagonal`).
pub(crate) const MIN_DIAGONAL: f64 = 1e-6;

/// The damping state of one LM run.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Damping {
    pub(crate) lambda: f64,
    nu: f64,
}

impl Damping {
    pub(crate) fn new() -> Self {
        Self {
            lambda: INITIAL_LAMBDA,
            nu: 2.0,
        }
    }

    /// The damping added to a diagonal entry `h` of the Hessian.
    #[inline]
    pub(crate) fn diagonal_term(&self, h: f64) -> f64 {
        self.lambda * h.max(MIN_DIAGONAL)
    }

    /// Updates after an accepted step with gain ratio `rho`.
    pub(crate) fn accept(&mut self, rho: f64) {
        let t = 2.0 * rho - 1.0;
        self.lambda = (self.lambda * (1.0 / 3.0f64).max(1.0 - t * t * t)).max(MIN_LAMBDA);
        self.nu = 2.0;
    }

    /// Updates after a rejected step; false when the damping has grown useless.
    pub(crate) fn reject(&mut self) -> bool {
        self.lambda *= self.nu;
        self.nu *= 2.0;
        self.lambda < MAX_LAMBDA
    }
}
