//! The block-sparse normal equations of the pose graph and their solution by faer's
//! sparse Cholesky.
//!
//! One 6x6 block per free node; the lower triangle holds the diagonal blocks and one
//! block per pair of free nodes joined by an edge (parallel edges share it). The
//! pattern and its symbolic analysis (AMD ordering, supernodal) are built once per
//! graph structure and reused by every LM iteration and every later optimisation of
//! the same graph; only the values are rewritten.

use super::PoseGraphError;
use crate::lm::Damping;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{Matrix6, Vector6};
use std::collections::HashMap;

/// Marks a fixed node (no block) or an edge with no off-diagonal block.
pub(crate) const NONE: usize = usize::MAX;

/// The damped system could not be factorised; the LM step is rejected.
pub(crate) struct NotPositiveDefinite;

/// The sparse matrix with a fixed pattern and its reusable factorisation buffers.
struct Factorization {
    matrix: SparseColMat<usize, f64>,
    /// For each stored (CSC) value of `matrix`, its index in the slot-major order.
    pattern_index: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    factor_values: Vec<f64>,
    scratch: MemBuffer,
}

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
    values: Vec<f64>,
    factorization: Option<Factorization>,
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
        self.factorization = None;
        let n = 6 * blocks;
        if n == 0 {
            return Ok(());
        }
        let mut pattern = Vec::with_capacity(self.slots.len() * 36);
        for &(rb, cb) in &self.slots {
            for c in 0..6 {
                for r in 0..6 {
                    if rb != cb || r >= c {
                        pattern.push(Pair {
                            row: 6 * rb + r,
                            col: 6 * cb + c,
                        });
                    }
                }
            }
        }
        let solver_error = |reason: String| PoseGraphError::Solver {
            dimension: n,
            reason,
        };
        let (pattern_csc, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &pattern)
            .map_err(|e| solver_error(format!("{e:?}")))?;
        // Each value equal to its pattern index: the CSC value array then tells where
        // every pattern entry is stored (exact below 2^53 entries), as in local BA.
        let indices: Vec<f64> = (0..pattern.len()).map(|i| i as f64).collect();
        let matrix = SparseColMat::new_from_argsort(pattern_csc, &argsort, &indices)
            .map_err(|e| solver_error(format!("{e:?}")))?;
        let pattern_index = matrix.val().iter().map(|&v| v as usize).collect();
        let symbolic = factorize_symbolic_cholesky(
            matrix.symbolic(),
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| solver_error(format!("{e:?}")))?;
        let scratch_req = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let scratch =
            MemBuffer::try_new(scratch_req).map_err(|e| solver_error(format!("{e:?}")))?;
        let factor_values = vec![0.0; symbolic.len_val()];
        self.factorization = Some(Factorization {
            matrix,
            pattern_index,
            symbolic,
            factor_values,
            scratch,
        });
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
        self.values.clear();
        for (value, &(rb, cb)) in self.h.iter().zip(&self.slots) {
            for c in 0..6 {
                for r in 0..6 {
                    if rb != cb {
                        self.values.push(value[(r, c)]);
                    } else if r >= c {
                        let damp = if r == c {
                            damping.diagonal_term(value[(r, c)])
                        } else {
                            0.0
                        };
                        self.values.push(value[(r, c)] + damp);
                    }
                }
            }
        }
        for (stored, &index) in f.matrix.val_mut().iter_mut().zip(&f.pattern_index) {
            *stored = self.values[index];
        }
        let factor = f
            .symbolic
            .factorize_numeric_llt(
                &mut f.factor_values,
                f.matrix.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut f.scratch),
                Default::default(),
            )
            .map_err(|_| NotPositiveDefinite)?;
        for (s, g) in self.step.iter_mut().zip(&self.g) {
            *s = -g;
        }
        let n = self.step.len();
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.step, n, 1),
            Par::Seq,
            MemStack::new(&mut f.scratch),
        );
        if !self.step.iter().all(|v| v.is_finite()) {
            return Err(NotPositiveDefinite);
        }
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
