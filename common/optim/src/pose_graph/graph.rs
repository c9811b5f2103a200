//! The pose graph: nodes, edges and the Levenberg-Marquardt loop.

use super::config::{PoseGraphConfig, PoseGraphError, PoseGraphKernel, PoseGraphReport};
use super::edge::{edge_error, linearize_edge};
use super::system::{NONE, NormalSystem};
use crate::lm::Damping;
use gfs_core::se3::retract;
use nalgebra::{Isometry3, Matrix6};

/// One relative-pose constraint between two nodes.
#[derive(Clone, Debug)]
struct Edge {
    from: usize,
    to: usize,
    /// The inverted measurement `to_from_from = (i_from_j)^-1`, as the error uses it.
    j_from_i: Isometry3<f64>,
    information: Matrix6<f64>,
}

/// A pose graph over SE(3) nodes, optimised in place by [`Self::optimize`].
///
/// Nodes are `world_from_camera` poses (`T_wc`); an edge `(i, j)` measures
/// `i_from_j = T_i^-1 T_j` with a 6x6 information matrix over `[translation;
/// rotation]` (the tangent order `[rho; phi]` of `gfs_core::se3`); the error, its
/// left-perturbation Jacobians and their derivation are in `edge.rs`. Keep one graph
/// and call [`Self::optimize`] again after [`Self::set_pose`]: the sparse structure and
/// its symbolic factorisation are kept until a node or an edge is added or a node's
/// fixed flag changes. Fix a node in every connected part of the graph: a part with no
/// fixed node has no defined position (LM only damps that freedom), and a free node
/// with no edge stays where it is.
///
/// ```
/// use gfs_optim::{PoseGraph, PoseGraphConfig};
/// use nalgebra::{Isometry3, Matrix6};
///
/// let mut graph = PoseGraph::new();
/// let a = graph.add_node(Isometry3::identity(), true);
/// let b = graph.add_node(Isometry3::translation(0.9, 0.1, 0.0), false);
/// graph.add_edge(a, b, Isometry3::translation(1.0, 0.0, 0.0), Matrix6::identity())?;
/// graph.optimize(&PoseGraphConfig::default())?;
/// assert!((graph.pose(b).translation.x - 1.0).abs() < 1e-9);
/// # Ok::<(), gfs_optim::PoseGraphError>(())
/// ```
#[derive(Default)]
pub struct PoseGraph {
    poses: Vec<Isometry3<f64>>,
    fixed: Vec<bool>,
    edges: Vec<Edge>,
    system: NormalSystem,
    /// The structure changed since the last analysis.
    stale: bool,
    candidate: Vec<Isometry3<f64>>,
}

impl PoseGraph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a node at `world_from_camera`, held constant by the optimisation when
    /// `fixed`; returns its index (0, 1, 2, ... in insertion order).
    pub fn add_node(&mut self, world_from_camera: Isometry3<f64>, fixed: bool) -> usize {
        self.poses.push(world_from_camera);
        self.fixed.push(fixed);
        self.stale = true;
        self.poses.len() - 1
    }

    /// Adds the constraint that node `to` is at `from_from_to` (`i_from_j = T_i^-1
    /// T_j`) seen from node `from`, with `information` (the inverse covariance of the
    /// tangent error `[rho; phi]`, symmetric positive semi-definite); returns its index.
    ///
    /// # Errors
    /// [`PoseGraphError::MissingNode`] when a node does not exist,
    /// [`PoseGraphError::NotFinite`] for a NaN / infinite measurement or information,
    /// [`PoseGraphError::BadInformation`] for a non-symmetric or indefinite one.
    pub fn add_edge(
        &mut self,
        from: usize,
        to: usize,
        from_from_to: Isometry3<f64>,
        information: Matrix6<f64>,
    ) -> Result<usize, PoseGraphError> {
        let nodes = self.poses.len();
        if from >= nodes || to >= nodes {
            return Err(PoseGraphError::MissingNode { from, to, nodes });
        }
        let edge = self.edges.len();
        let finite = from_from_to
            .translation
            .vector
            .iter()
            .all(|v| v.is_finite())
            && from_from_to.rotation.coords.iter().all(|v| v.is_finite())
            && information.iter().all(|v| v.is_finite());
        if !finite {
            return Err(PoseGraphError::NotFinite {
                what: "edge",
                index: edge,
            });
        }
        let asymmetry = (information - information.transpose()).abs().max();
        let scale = information.abs().max().max(f64::MIN_POSITIVE);
        let semi_definite = information
            .symmetric_eigenvalues()
            .iter()
            .all(|&l| l >= -1e-9 * scale);
        if asymmetry > 1e-9 * scale || !semi_definite {
            return Err(PoseGraphError::BadInformation { edge });
        }
        self.edges.push(Edge {
            from,
            to,
            j_from_i: from_from_to.inverse(),
            information,
        });
        self.stale = true;
        Ok(edge)
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.poses.len()
    }

    /// Number of edges.
    pub fn num_edges(&self) -> usize {
        self.edges.len()
    }

    /// The current `world_from_camera` of node `node`.
    ///
    /// # Panics
    /// When `node` was not returned by [`Self::add_node`] (a bug of the caller).
    pub fn pose(&self, node: usize) -> &Isometry3<f64> {
        &self.poses[node]
    }

    /// Every node's current pose, in index order.
    pub fn poses(&self) -> &[Isometry3<f64>] {
        &self.poses
    }

    /// Moves node `node` (e.g. to restart from new estimates).
    ///
    /// # Panics
    /// When `node` does not exist (a bug of the caller).
    pub fn set_pose(&mut self, node: usize, world_from_camera: Isometry3<f64>) {
        self.poses[node] = world_from_camera;
    }

    /// Holds node `node` constant (or frees it).
    ///
    /// # Panics
    /// When `node` does not exist (a bug of the caller).
    pub fn set_fixed(&mut self, node: usize, fixed: bool) {
        self.stale |= self.fixed[node] != fixed;
        self.fixed[node] = fixed;
    }

    /// Squared whitened error `e^T Omega e` of edge `edge` at the current poses (compare
    /// with a chi-square quantile, 6 dof, to flag a wrong loop edge).
    ///
    /// # Panics
    /// When `edge` does not exist (a bug of the caller).
    pub fn edge_chi2(&self, edge: usize) -> f64 {
        let e = &self.edges[edge];
        let r = edge_error(&e.j_from_i, &self.poses[e.from], &self.poses[e.to]);
        r.dot(&(e.information * r))
    }

    /// Optimises the free nodes in place by Levenberg-Marquardt.
    ///
    /// Each iteration linearises every edge (analytic Jacobians, left perturbation),
    /// weighs it by the kernel (IRLS), solves the damped normal equations with faer's
    /// sparse Cholesky and keeps the step only if the robust cost decreases. The poses
    /// left are the best reached. LM starts from the current poses: it converged from
    /// 100 degrees of yaw drift closed by one loop edge in the tests, not from 200;
    /// for a loop that far off, first move the loop's side of the graph by the loop
    /// correction (as ORB-SLAM2 does before its essential-graph optimisation).
    ///
    /// # Errors
    /// [`PoseGraphError::NoFixedNode`] when no node is fixed (while some edge exists),
    /// [`PoseGraphError::KernelDelta`] for a kernel threshold that is not positive,
    /// [`PoseGraphError::NotFinite`] for a node with a NaN / infinite pose,
    /// [`PoseGraphError::Solver`] when faer cannot set up the factorisation; the poses are
    /// then unchanged.
    pub fn optimize(
        &mut self,
        config: &PoseGraphConfig,
    ) -> Result<PoseGraphReport, PoseGraphError> {
        if let Some(index) = self.poses.iter().position(|p| {
            !(p.translation.vector.iter().all(|v| v.is_finite())
                && p.rotation.coords.iter().all(|v| v.is_finite()))
        }) {
            return Err(PoseGraphError::NotFinite {
                what: "node",
                index,
            });
        }
        let delta = config.kernel_delta;
        if config.kernel != PoseGraphKernel::None && !(delta.is_finite() && delta > 0.0) {
            return Err(PoseGraphError::KernelDelta(delta));
        }
        if !self.edges.is_empty() && !self.fixed.iter().any(|&f| f) {
            return Err(PoseGraphError::NoFixedNode {
                nodes: self.poses.len(),
            });
        }
        if self.stale {
            let edges = self.edges.iter().map(|e| (e.from, e.to));
            self.system.analyse(&self.fixed, edges)?;
            self.stale = false;
        }
        let mut report = PoseGraphReport::default();
        let mut cost = self.linearize(config);
        report.initial_cost = cost;
        report.final_cost = cost;
        if self.system.blocks() == 0 || cost <= 0.0 {
            report.converged = true;
            return Ok(report);
        }
        let mut damping = Damping::new();
        for _ in 0..config.max_iterations {
            let mut accepted = None;
            loop {
                report.linear_solves += 1;
                if let Ok(predicted) = self.system.solve(&damping) {
                    self.apply_step();
                    let candidate_cost = self.cost(&self.candidate, config);
                    if candidate_cost < cost {
                        damping.accept((cost - candidate_cost) / predicted.max(f64::MIN_POSITIVE));
                        accepted = Some(candidate_cost);
                        break;
                    }
                }
                if !damping.reject() {
                    break;
                }
            }
            // No decrease at any damping: a minimum to working precision.
            let Some(new_cost) = accepted else {
                report.converged = true;
                break;
            };
            std::mem::swap(&mut self.poses, &mut self.candidate);
            report.iterations += 1;
            report.final_cost = new_cost;
            let gain = cost - new_cost;
            if gain <= config.relative_tolerance * cost {
                report.converged = true;
                break;
            }
            cost = self.linearize(config);
        }
        Ok(report)
    }

    /// Robust cost of every edge at `poses`.
    fn cost(&self, poses: &[Isometry3<f64>], config: &PoseGraphConfig) -> f64 {
        self.edges
            .iter()
            .map(|e| {
                let r = edge_error(&e.j_from_i, &poses[e.from], &poses[e.to]);
                config
                    .kernel
                    .cost(r.dot(&(e.information * r)), config.kernel_delta)
            })
            .sum()
    }

    /// Fills the normal equations at the current poses; returns the robust cost.
    fn linearize(&mut self, config: &PoseGraphConfig) -> f64 {
        let system = &mut self.system;
        system.clear();
        let mut cost = 0.0;
        for (k, e) in self.edges.iter().enumerate() {
            let (r, jac) = linearize_edge(&e.j_from_i, &self.poses[e.from], &self.poses[e.to]);
            let omega_r = e.information * r;
            let s = r.dot(&omega_r);
            cost += config.kernel.cost(s, config.kernel_delta);
            // A self-edge's error does not depend on its node (J - J = 0).
            if e.from == e.to {
                continue;
            }
            let w = config.kernel.weight(s, config.kernel_delta);
            // de/dd_from = -J, de/dd_to = J.
            let jt_omega = jac.transpose() * (w * e.information);
            let h = jt_omega * jac;
            let g = jt_omega * r;
            let (a, b) = (system.block_of_node[e.from], system.block_of_node[e.to]);
            if a != NONE {
                system.h[a] += h;
                system.add_gradient(a, &(-g));
            }
            if b != NONE {
                system.h[b] += h;
                system.add_gradient(b, &g);
            }
            let slot = system.edge_slot[k];
            if slot != NONE {
                system.h[slot] -= h;
            }
        }
        cost
    }

    /// `candidate = poses ⊕ step` (left perturbation of the free nodes).
    fn apply_step(&mut self) {
        self.candidate.clone_from(&self.poses);
        for (pose, &b) in self.candidate.iter_mut().zip(&self.system.block_of_node) {
            if b != NONE {
                *pose = retract(pose, &self.system.block_step(b));
            }
        }
    }
}
