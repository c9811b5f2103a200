//! The sparse Cholesky of a symmetric matrix of 6x6 blocks with a fixed pattern, shared
//! by the reduced camera system of local BA and the normal equations of the pose graph.
//!
//! The pattern (the lower triangle: every diagonal block and the off-diagonal blocks
//! listed as slots) and its symbolic analysis (AMD ordering, supernodal) are built once;
//! each solve only rewrites the values and factorises them again.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::Matrix6;

/// The matrix could not be factorised or gave a non-finite solution (the LM step is
/// then rejected).
pub(crate) struct NotPositiveDefinite;

/// The matrix with its pattern and every factorisation buffer allocated once.
pub(crate) struct BlockCholesky {
    matrix: SparseColMat<usize, f64>,
    /// For each stored (CSC) value of `matrix`, its index in the slot-major order.
    pattern_index: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    factor_values: Vec<f64>,
    scratch: MemBuffer,
    values: Vec<f64>,
}

impl BlockCholesky {
    /// Analyses the pattern of `slots`, (row block, column block) pairs with
    /// row >= column, over `blocks` blocks; `None` when there is no block.
    ///
    /// # Errors
    /// faer's reason when it cannot build the pattern or its analysis.
    pub(crate) fn analyse(blocks: usize, slots: &[(usize, usize)]) -> Result<Option<Self>, String> {
        let n = 6 * blocks;
        if n == 0 {
            return Ok(None);
        }
        let mut pattern = Vec::with_capacity(slots.len() * 36);
        for &(rb, cb) in slots {
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
        let (pattern_csc, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &pattern)
            .map_err(|e| format!("{e:?}"))?;
        // Build the matrix with each value equal to its pattern index, so that its CSC
        // value array tells where every pattern entry goes (exact below 2^53 entries).
        let indices: Vec<f64> = (0..pattern.len()).map(|i| i as f64).collect();
        let matrix = SparseColMat::new_from_argsort(pattern_csc, &argsort, &indices)
            .map_err(|e| format!("{e:?}"))?;
        let pattern_index = matrix.val().iter().map(|&v| v as usize).collect();
        let symbolic = factorize_symbolic_cholesky(
            matrix.symbolic(),
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| format!("{e:?}"))?;
        let scratch_req = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let scratch = MemBuffer::try_new(scratch_req).map_err(|e| format!("{e:?}"))?;
        let factor_values = vec![0.0; symbolic.len_val()];
        Ok(Some(Self {
            matrix,
            pattern_index,
            symbolic,
            factor_values,
            scratch,
            values: Vec::with_capacity(pattern.len()),
        }))
    }

    /// Factorises the matrix whose slot `s` (of the `slots` it was analysed with) is
    /// `value(s)` and overwrites `rhs` with the solution.
    pub(crate) fn factor_and_solve(
        &mut self,
        slots: &[(usize, usize)],
        value: impl Fn(usize) -> Matrix6<f64>,
        rhs: &mut [f64],
    ) -> Result<(), NotPositiveDefinite> {
        self.values.clear();
        for (s, &(rb, cb)) in slots.iter().enumerate() {
            let value = value(s);
            for c in 0..6 {
                for r in 0..6 {
                    if rb != cb || r >= c {
                        self.values.push(value[(r, c)]);
                    }
                }
            }
        }
        for (stored, &index) in self.matrix.val_mut().iter_mut().zip(&self.pattern_index) {
            *stored = self.values[index];
        }
        let factor = self
            .symbolic
            .factorize_numeric_llt(
                &mut self.factor_values,
                self.matrix.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.scratch),
                Default::default(),
            )
            .map_err(|_| NotPositiveDefinite)?;
        let n = rhs.len();
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.scratch),
        );
        if rhs.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(NotPositiveDefinite)
        }
    }
}
