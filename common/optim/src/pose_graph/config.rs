//! Parameters, report and errors of the pose-graph optimisation.

use serde::Deserialize;

/// 95 % quantile of the chi-square distribution with 6 degrees of freedom: the
/// default kernel threshold for an edge whose information is its inverse covariance.
pub const CHI2_6DOF_95: f64 = 12.592;

/// Robust kernel applied to each edge's squared whitened error `s = e^T Omega e`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoseGraphKernel {
    /// Plain least squares (ORB-SLAM2's essential-graph optimisation).
    #[default]
    None,
    /// Huber: quadratic below `delta^2`, linear above; bounds an outlier's pull.
    Huber,
    /// Cauchy: `delta^2 ln(1 + s / delta^2)`; an outlier's pull fades as it grows, the
    /// kernel to use when a wrong loop edge may have been accepted.
    Cauchy,
}

impl PoseGraphKernel {
    /// Robust cost `rho(s)` for threshold `delta`.
    #[inline]
    pub fn cost(self, s: f64, delta: f64) -> f64 {
        let d2 = delta * delta;
        match self {
            Self::None => s,
            Self::Huber if s <= d2 => s,
            Self::Huber => 2.0 * delta * s.sqrt() - d2,
            Self::Cauchy => d2 * (s / d2).ln_1p(),
        }
    }

    /// IRLS weight `rho'(s)`: the normal equations use `J^T (w Omega) J`, `J^T (w Omega) e`.
    #[inline]
    pub fn weight(self, s: f64, delta: f64) -> f64 {
        let d2 = delta * delta;
        match self {
            Self::None => 1.0,
            Self::Huber if s <= d2 => 1.0,
            Self::Huber => delta / s.sqrt(),
            Self::Cauchy => 1.0 / (1.0 + s / d2),
        }
    }
}

/// Parameters of [`crate::PoseGraph::optimize`].
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseGraphConfig {
    /// Levenberg-Marquardt iterations at most; default 20 (ORB-SLAM2's essential graph).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction of it;
    /// default 1e-9 (loop corrections spread over hundreds of edges make tiny relative
    /// gains still worth a few iterations).
    pub relative_tolerance: f64,
    /// Robust kernel of every edge; default none.
    pub kernel: PoseGraphKernel,
    /// Threshold of the kernel on the whitened error norm `sqrt(s)`; default
    /// `sqrt(12.592)` (chi-square, 6 dof, 95 %), meaningful when the information
    /// matrices are inverse covariances.
    pub kernel_delta: f64,
}

impl Default for PoseGraphConfig {
    fn default() -> Self {
        Self {
            max_iterations: 20,
            relative_tolerance: 1e-9,
            kernel: PoseGraphKernel::None,
            kernel_delta: CHI2_6DOF_95.sqrt(),
        }
    }
}

/// What an optimisation did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseGraphReport {
    /// Robust cost `sum rho(e^T Omega e)` at the initial poses.
    pub initial_cost: f64,
    /// Robust cost at the final poses.
    pub final_cost: f64,
    /// Accepted LM iterations.
    pub iterations: usize,
    /// Damped systems factorised (accepted plus rejected steps).
    pub linear_solves: usize,
    /// True when LM stopped on the tolerance (or at a minimum it could not improve),
    /// false when it ran out of iterations; the poses are the best reached either way.
    pub converged: bool,
}

/// Why a pose graph could not be built or optimised.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PoseGraphError {
    /// An edge names a node that does not exist.
    #[error("pose-graph edge ({from}, {to}) names a node beyond the {nodes} nodes of the graph")]
    MissingNode {
        /// First node of the edge.
        from: usize,
        /// Second node of the edge.
        to: usize,
        /// Nodes in the graph.
        nodes: usize,
    },
    /// A pose, measurement or information matrix holds NaN or infinity.
    #[error("pose-graph {what} {index} is not finite")]
    NotFinite {
        /// "node" or "edge".
        what: &'static str,
        /// Its index.
        index: usize,
    },
    /// An information matrix is not symmetric positive semi-definite.
    #[error("information matrix of pose-graph edge {edge} is not symmetric positive semi-definite")]
    BadInformation {
        /// Index of the edge.
        edge: usize,
    },
    /// A robust kernel with a threshold that is not a positive number.
    #[error("pose-graph kernel threshold {0} is not positive and finite")]
    KernelDelta(f64),
    /// Every node is free: the graph's pose is not observable (gauge freedom).
    #[error("pose graph of {nodes} nodes fixes none of them")]
    NoFixedNode {
        /// Nodes in the graph.
        nodes: usize,
    },
    /// faer could not set up the sparse factorisation.
    #[error("sparse solver of the pose graph (dimension {dimension}): {reason}")]
    Solver {
        /// Size of the linear system.
        dimension: usize,
        /// faer's message.
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_weights_are_the_derivatives_of_the_costs() {
        for kernel in [
            PoseGraphKernel::None,
            PoseGraphKernel::Huber,
            PoseGraphKernel::Cauchy,
        ] {
            for s in [0.5, 3.0, 40.0, 900.0] {
                let numeric = (kernel.cost(s + 1e-6, 2.0) - kernel.cost(s - 1e-6, 2.0)) / 2e-6;
                assert!(
                    (numeric - kernel.weight(s, 2.0)).abs() < 1e-6,
                    "{kernel:?} at {s}"
                );
            }
        }
        // Cauchy at s = delta^2: delta^2 ln 2, weight 1/2.
        assert!((PoseGraphKernel::Cauchy.cost(4.0, 2.0) - 4.0 * 2f64.ln()).abs() < 1e-12);
        assert_eq!(PoseGraphKernel::Cauchy.weight(4.0, 2.0), 0.5);
    }

    #[test]
    fn config_reads_from_toml() {
        #[derive(Deserialize)]
        struct Table {
            pose_graph: PoseGraphConfig,
        }
        let t: Table = toml::from_str("[pose_graph]\nkernel = \"cauchy\"\nmax_iterations = 5")
            .expect("valid table");
        assert_eq!(t.pose_graph.kernel, PoseGraphKernel::Cauchy);
        assert_eq!(t.pose_graph.max_iterations, 5);
        assert!((t.pose_graph.kernel_delta - 12.592f64.sqrt()).abs() < 1e-12);
    }
}
