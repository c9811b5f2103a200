//! The block-sparse normal equations of the pose graph and their solution by faer's
//! sparse Cholesky.
//!
//! One 6x6 block per free node; the lower triangle holds the diagonal blocks and one
//! block per pair of free nodes joined by an edge (parallel edges share it). The
//! pattern and its symbolic analysis (AMD ordering, supernodal) are built once per
//! graph structure and reused by every LM iteration and every later optimisation of
//! the same graph; only the values are rewritten.

use super::PoseGraphError;
use crate::block_cholesky::BlockCholesky;
use crate::block_cholesky::NotPositiveDefinite;
use crate::lm::Damping;
use nalgebra::{Matrix6, Vector6};
use std::collections::HashMap;

/// Marks a fixed node (no block) or an edge with no off-diagonal block.
pub(crate) const NONE: usize = usize::MAX;

/// Normal equations `H d = -g` over the free nodes, with their block structure.
#[derive(Default)]
pub(crate) struct NormalSystem {
    /// Block of each node, [`NONE`] when fixed.
    pub(crate) block_of_node: Vec<usize>,
    /// Off-diagonal slot of each edge, [`NONE`] when an end is fixed or both are equal.
    pub(crate) edge_slot: Vec<usize>,
    /// (row block, column block) of each slot, row >= column; slot `b` is block `b`'s
    /// diagonal.
    slots: Vec<(usize, usize)>,
    /// Undamped value of each slot.
    pub(crate) h: Vec<Matrix6<f64>>,
    /// Gradient `J^T W e`, 6 per block.
    pub(crate) g: Vec<f64>,
    /// The step, 6 per block, after [`Self::solve`].
    pub(crate) step: Vec<f64>,
    factorization: Option<BlockCholesky>,
}

impl NormalSystem {
    /// Number of free blocks.
    pub(crate) fn blocks(&self) -> usize {
        self.g.len() / 6
    }

    /// Builds the block pattern for the graph's fixed flags and edges, and its symbolic
    /// factorisation.
    ///
    /// # Errors
    /// [`PoseGraphError::Solver`] when faer cannot build the pattern or its analysis.
    pub(crate) fn analyse(
        &mut self,
        fixed: &[bool],
        edges: impl Iterator<Item = (usize, usize)>,
    ) -> Result<(), PoseGraphError> {
        self.block_of_node.clear();
        let mut blocks = 0;
        for &f in fixed {
            self.block_of_node.push(if f { NONE } else { blocks });
            blocks += usize::from(!f);
        }
        self.slots.clear();
        self.slots.extend((0..blocks).map(|b| (b, b)));
        let mut slot_of = HashMap::new();
        self.edge_slot.clear();
        for (i, j) in edges {
            let (a, b) = (self.block_of_node[i], self.block_of_node[j]);
            let slot = if a == NONE || b == NONE || a == b {
                NONE
            } else {
                let key = (a.max(b), a.min(b));
                let next = self.slots.len();
                let slot = *slot_of.entry(key).or_insert(next);
                if slot == next {
                    self.slots.push(key);
                }
                slot
            };
            self.edge_slot.push(slot);
        }
        self.h.clear();
        self.h.resize(self.slots.len(), Matrix6::zeros());
        self.g.clear();
        self.g.resize(6 * blocks, 0.0);
        self.step.clear();
        self.step.resize(6 * blocks, 0.0);
        self.factorization = BlockCholesky::analyse(blocks, &self.slots).map_err(|reason| {
            PoseGraphError::Solver {
                dimension: 6 * blocks,
                reason,
            }
        })?;
        Ok(())
    }

    /// Zeroes the values before a linearisation.
    pub(crate) fn clear(&mut self) {
        self.h.fill(Matrix6::zeros());
        self.g.fill(0.0);
    }

    /// Adds `v` to the gradient of block `b`.
    #[inline]
    pub(crate) fn add_gradient(&mut self, b: usize, v: &Vector6<f64>) {
        for (g, v) in self.g[6 * b..6 * b + 6].iter_mut().zip(v.iter()) {
            *g += v;
        }
    }

    /// Solves `(H + lambda D) d = -g` into `step`; returns the decrease of the cost
    /// predicted by the linear model, `lambda d^T D d - g^T d` (see `crate::lm`).
    pub(crate) fn solve(&mut self, damping: &Damping) -> Result<f64, NotPositiveDefinite> {
        let Some(f) = &mut self.factorization else {
            return Ok(0.0);
        };
        for (s, g) in self.step.iter_mut().zip(&self.g) {
            *s = -g;
        }
        let (h, slots) = (&self.h, &self.slots);
        let damped = |slot: usize| {
            let mut value = h[slot];
            if slots[slot].0 == slots[slot].1 {
                for k in 0..6 {
                    value[(k, k)] += damping.diagonal_term(h[slot][(k, k)]);
                }
            }
            value
        };
        f.factor_and_solve(damped, &mut self.step)?;
        let mut predicted = 0.0;
        for b in 0..self.blocks() {
            let h = &self.h[b];
            for k in 0..6 {
                let d = self.step[6 * b + k];
                predicted += damping.diagonal_term(h[(k, k)]) * d * d - self.g[6 * b + k] * d;
            }
        }
        Ok(predicted)
    }

    /// The step of block `b`.
    pub(crate) fn block_step(&self, b: usize) -> Vector6<f64> {
        Vector6::from_column_slice(&self.step[6 * b..6 * b + 6])
    }
}
