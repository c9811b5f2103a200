//! The normal equations of local BA and their solution by the Schur complement.
//!
//! Variables: free poses (6), points (3), lines (6: both endpoints). Point blocks are
//! independent of each other, and so are the blocks of lines that take part in no
//! structural pair (a Manhattan term touches one line only): those landmarks are
//! eliminated exactly, block by block, into the pose system. A parallel or
//! perpendicular pair couples two lines, so its lines are *kept* in the reduced system
//! beside the free poses instead of being eliminated: the reduced matrix is then
//! `[[S_pp, H_pl], [H_lp, H_ll]]` with `H_ll` block-sparse (one off-diagonal block per
//! pair). It is solved by faer's sparse Cholesky (block AMD ordering, supernodal), whose
//! symbolic analysis is reused at every LM iteration while the pattern holds. This is
//! the exact Gauss-Newton/LM step, no approximation; its cost grows with the density
//! of the pair graph, so give each line a few partners rather than all.
//!
//! Planes (3 dof) are eliminated as points are, unless a parallel or perpendicular
//! plane pair couples them: a kept plane fills the upper half of a 6x6 block whose
//! lower half is an identity coupled to nothing (its step is zero), so that the one
//! block Cholesky of 6x6 blocks solves it with the poses and the kept lines.

mod pattern;

use super::normal::{Linearization, Step};
use super::problem::BaProblem;
use crate::block_cholesky::{BlockCholesky, NotPositiveDefinite};
use crate::lm::Damping;
use nalgebra::{Matrix3, Matrix6, Matrix6x3, Vector3, Vector6};
use std::collections::HashMap;

/// Marks "no block / no slot".
const NONE: usize = usize::MAX;

/// Observations of one eliminated landmark: (observation index, pose block).
type ObsLists = (Vec<usize>, Vec<(usize, usize)>);

/// Structure of the reduced system for one pass (fixed active sets) plus its scratch.
#[derive(Default)]
pub(crate) struct ReducedSystem {
    pose_block: Vec<usize>,
    line_block: Vec<usize>,
    plane_block: Vec<usize>,
    point_used: Vec<bool>,
    line_used: Vec<bool>,
    plane_used: Vec<bool>,
    /// Used planes outside every plane pair (eliminated, not kept).
    plane_eliminated: Vec<bool>,
    /// CSR lists of the active observations with a free pose, per point.
    point_obs: ObsLists,
    /// Same per eliminated plane.
    plane_obs: ObsLists,
    /// Same per eliminated line.
    line_obs: ObsLists,
    blocks: usize,
    slots: Vec<(usize, usize)>,
    slot_of: HashMap<(usize, usize), usize>,
    line_obs_slot: Vec<usize>,
    parallel_slot: Vec<usize>,
    perpendicular_slot: Vec<usize>,
    plane_obs_slot: Vec<usize>,
    plane_parallel_slot: Vec<usize>,
    plane_perpendicular_slot: Vec<usize>,
    factorization: Option<BlockCholesky>,
    slot_values: Vec<Matrix6<f64>>,
    rhs: Vec<f64>,
    point_inverse: Vec<Matrix3<f64>>,
    plane_inverse: Vec<Matrix3<f64>>,
    line_inverse: Vec<Matrix6<f64>>,
    scratch_y3: Vec<Matrix6x3<f64>>,
    scratch_y6: Vec<Matrix6<f64>>,
}

/// Slot of the pose-pose block (`a`, `b`), `a >= b`: those slots are created first, row
/// by row, so their index is arithmetic (no hashing in the Schur loops).
#[inline]
fn pose_pair_slot(a: usize, b: usize) -> usize {
    a * (a + 1) / 2 + b
}

/// `s -= y * w^T` for 6xC `y` and `w`, written as column axpys on the column-major
/// storage so that the compiler vectorises it (the Schur loops' hot spot).
#[inline]
fn sub_outer<const C: usize>(
    s: &mut Matrix6<f64>,
    y: &nalgebra::SMatrix<f64, 6, C>,
    w: &nalgebra::SMatrix<f64, 6, C>,
) {
    let s = s.as_mut_slice();
    let (y, w) = (y.as_slice(), w.as_slice());
    for c in 0..6 {
        let column = &mut s[6 * c..6 * c + 6];
        for k in 0..C {
            let f = w[6 * k + c];
            let y_col = &y[6 * k..6 * k + 6];
            for r in 0..6 {
                column[r] -= y_col[r] * f;
            }
        }
    }
}

/// Damping scale of a landmark block: its diagonal plus its mean diagonal. Plain
/// Marquardt scaling cannot damp a direction that is weak but not axis-aligned (a
/// point's depth seen from a short baseline, a line's endpoint sliding along it): the
/// isotropic part keeps those steps bounded, so fewer LM steps are rejected.
#[inline]
fn landmark_scale<const N: usize>(h: &nalgebra::SMatrix<f64, N, N>) -> nalgebra::SVector<f64, N> {
    let mean = h.trace() / N as f64;
    h.diagonal().add_scalar(mean)
}

/// `h + lambda * diag(scale)` with the LM diagonal clamping.
#[inline]
fn damped<const N: usize>(
    h: &nalgebra::SMatrix<f64, N, N>,
    scale: &nalgebra::SVector<f64, N>,
    damping: &Damping,
) -> nalgebra::SMatrix<f64, N, N> {
    let mut a = *h;
    for k in 0..N {
        a[(k, k)] += damping.diagonal_term(scale[k]);
    }
    a
}

/// A 3x3 block of a kept plane in the top-left corner of a 6x6 slot.
#[inline]
fn embed3(m: &Matrix3<f64>) -> Matrix6<f64> {
    let mut out = Matrix6::zeros();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(m);
    out
}

/// Writes a 6-vector into block `block` of `rhs`.
fn set_rhs(rhs: &mut [f64], block: usize, value: &Vector6<f64>) {
    rhs[6 * block..6 * block + 6].copy_from_slice(value.as_slice());
}

impl ReducedSystem {
    /// Adds the kept planes' blocks: the damped diagonal (identity in its unused lower
    /// half), the pose couplings and the pairs.
    fn add_kept_planes(&mut self, p: &BaProblem, lin: &Linearization, damping: &Damping) {
        for q in 0..p.planes.len() {
            let kept = self.plane_block[q];
            if kept == NONE {
                continue;
            }
            let h = &lin.h_plane[q];
            let mut block = embed3(&damped(h, &landmark_scale(h), damping));
            block
                .fixed_view_mut::<3, 3>(3, 3)
                .copy_from(&Matrix3::identity());
            self.slot_values[self.slot_of[&(kept, kept)]] += block;
            let g = -lin.g_plane[q];
            self.rhs[6 * kept..6 * kept + 3].copy_from_slice(g.as_slice());
        }
        for k in 0..p.plane_observations.len() {
            let slot = self.plane_obs_slot[k];
            if slot != NONE {
                let mut top = self.slot_values[slot].fixed_view_mut::<3, 6>(0, 0);
                top += lin.w_plane_obs[k].transpose();
            }
        }
        let pair_lists = [
            (
                &p.plane_parallel,
                &self.plane_parallel_slot,
                &lin.h_plane_parallel,
            ),
            (
                &p.plane_perpendicular,
                &self.plane_perpendicular_slot,
                &lin.h_plane_perpendicular,
            ),
        ];
        for (pairs, slots, h) in pair_lists {
            for (k, &(i, j)) in pairs.iter().enumerate() {
                let slot = slots[k];
                if slot == NONE {
                    continue;
                }
                if self.plane_block[i] > self.plane_block[j] {
                    self.slot_values[slot] += embed3(&h[k]);
                } else {
                    self.slot_values[slot] += embed3(&h[k].transpose());
                }
            }
        }
    }

    /// Solves the damped normal equations for the step; returns the decrease of the
    /// cost predicted by the linear model.
    pub(crate) fn solve(
        &mut self,
        p: &BaProblem,
        lin: &Linearization,
        damping: &Damping,
        step: &mut Step,
    ) -> Result<f64, NotPositiveDefinite> {
        self.slot_values.clear();
        self.slot_values.resize(self.slots.len(), Matrix6::zeros());
        self.rhs.clear();
        self.rhs.resize(6 * self.blocks, 0.0);
        self.point_inverse.resize(p.points.len(), Matrix3::zeros());
        self.plane_inverse.resize(p.planes.len(), Matrix3::zeros());
        self.line_inverse.resize(p.lines.len(), Matrix6::zeros());

        for (i, &b) in self.pose_block.iter().enumerate() {
            if b != NONE {
                let h = &lin.h_pose[i];
                self.slot_values[pose_pair_slot(b, b)] += damped(h, &h.diagonal(), damping);
                set_rhs(&mut self.rhs, b, &(-lin.g_pose[i]));
            }
        }
        // Eliminate points and planes, 3-dof landmarks (the Schur complement:
        // S -= W A^-1 W^T, r += W A^-1 g).
        Self::eliminate3(
            Landmarks3 {
                used: &self.point_used,
                obs: &self.point_obs,
                h: &lin.h_point,
                g: &lin.g_point,
                w_obs: &lin.w_point_obs,
            },
            damping,
            &mut self.point_inverse,
            SchurTarget {
                scratch: &mut self.scratch_y3,
                rhs: &mut self.rhs,
                slot_values: &mut self.slot_values,
            },
        )?;
        Self::eliminate3(
            Landmarks3 {
                used: &self.plane_eliminated,
                obs: &self.plane_obs,
                h: &lin.h_plane,
                g: &lin.g_plane,
                w_obs: &lin.w_plane_obs,
            },
            damping,
            &mut self.plane_inverse,
            SchurTarget {
                scratch: &mut self.scratch_y3,
                rhs: &mut self.rhs,
                slot_values: &mut self.slot_values,
            },
        )?;
        // Eliminate the lines outside every structural pair the same way; keep the others.
        for l in 0..p.lines.len() {
            if !self.line_used[l] {
                continue;
            }
            let kept = self.line_block[l];
            if kept != NONE {
                let h = &lin.h_line[l];
                self.slot_values[self.slot_of[&(kept, kept)]] +=
                    damped(h, &landmark_scale(h), damping);
                set_rhs(&mut self.rhs, kept, &(-lin.g_line[l]));
                continue;
            }
            let h = &lin.h_line[l];
            let inverse = damped(h, &landmark_scale(h), damping)
                .cholesky()
                .ok_or(NotPositiveDefinite)?
                .inverse();
            self.line_inverse[l] = inverse;
            let (start, entries) = &self.line_obs;
            let list = &entries[start[l]..start[l + 1]];
            self.scratch_y6.clear();
            for &(k, b) in list {
                let y = lin.w_line_obs[k] * inverse;
                let r = y * lin.g_line[l];
                for c in 0..6 {
                    self.rhs[6 * b + c] += r[c];
                }
                self.scratch_y6.push(y);
            }
            for (ya, &(_, ba)) in self.scratch_y6.iter().zip(list) {
                for &(kb, bb) in list {
                    if ba >= bb {
                        sub_outer(
                            &mut self.slot_values[pose_pair_slot(ba, bb)],
                            ya,
                            &lin.w_line_obs[kb],
                        );
                    }
                }
            }
        }
        // Couplings of the kept lines: with the poses observing them and their pairs.
        for k in 0..p.line_observations.len() {
            let slot = self.line_obs_slot[k];
            if slot != NONE {
                self.slot_values[slot] += lin.w_line_obs[k].transpose();
            }
        }
        let pair_lists = [
            (&p.parallel, &self.parallel_slot, &lin.h_parallel),
            (
                &p.perpendicular,
                &self.perpendicular_slot,
                &lin.h_perpendicular,
            ),
        ];
        for (pairs, slots, h) in pair_lists {
            for (k, &(i, j)) in pairs.iter().enumerate() {
                let slot = slots[k];
                if slot == NONE {
                    continue;
                }
                if self.line_block[i] > self.line_block[j] {
                    self.slot_values[slot] += h[k];
                } else {
                    self.slot_values[slot] += h[k].transpose();
                }
            }
        }
        self.add_kept_planes(p, lin, damping);
        self.factor_and_solve()?;
        Ok(self.back_substitute(p, lin, damping, step))
    }

    /// Eliminates the used 3-dof landmarks of one kind (points or planes) into the
    /// reduced system, keeping each one's damped inverse for the back-substitution.
    fn eliminate3(
        landmarks: Landmarks3,
        damping: &Damping,
        inverses: &mut [Matrix3<f64>],
        reduced: SchurTarget,
    ) -> Result<(), NotPositiveDefinite> {
        let Landmarks3 {
            used,
            obs,
            h,
            g,
            w_obs,
        } = landmarks;
        let SchurTarget {
            scratch,
            rhs,
            slot_values,
        } = reduced;
        let (start, entries) = obs;
        for x in 0..used.len() {
            if !used[x] {
                continue;
            }
            let inverse = damped(&h[x], &landmark_scale(&h[x]), damping)
                .cholesky()
                .ok_or(NotPositiveDefinite)?
                .inverse();
            inverses[x] = inverse;
            let list = &entries[start[x]..start[x + 1]];
            scratch.clear();
            for &(k, b) in list {
                let y = w_obs[k] * inverse;
                let r = y * g[x];
                for c in 0..6 {
                    rhs[6 * b + c] += r[c];
                }
                scratch.push(y);
            }
            for (ya, &(_, ba)) in scratch.iter().zip(list) {
                for &(kb, bb) in list {
                    if ba >= bb {
                        sub_outer(&mut slot_values[pose_pair_slot(ba, bb)], ya, &w_obs[kb]);
                    }
                }
            }
        }
        Ok(())
    }

    /// Factorises the reduced matrix and overwrites `rhs` with the reduced step.
    fn factor_and_solve(&mut self) -> Result<(), NotPositiveDefinite> {
        let Some(f) = &mut self.factorization else {
            return Ok(());
        };
        let values = &self.slot_values;
        f.factor_and_solve(|slot| values[slot], &mut self.rhs)
    }

    fn reduced_step(&self, block: usize) -> Vector6<f64> {
        Vector6::from_column_slice(&self.rhs[6 * block..6 * block + 6])
    }

    /// Recovers the eliminated landmarks' steps and returns the predicted decrease
    /// `lambda delta^T D delta - g^T delta` (see `crate::lm`).
    fn back_substitute(
        &self,
        p: &BaProblem,
        lin: &Linearization,
        damping: &Damping,
        step: &mut Step,
    ) -> f64 {
        let mut predicted = 0.0;
        let mut add = |scale: &[f64], g: &[f64], d: &[f64]| {
            for ((h, g), d) in scale.iter().zip(g).zip(d) {
                predicted += damping.diagonal_term(*h) * d * d - g * d;
            }
        };
        step.pose.clear();
        step.pose.resize(p.poses.len(), Vector6::zeros());
        for (i, &b) in self.pose_block.iter().enumerate() {
            if b != NONE {
                step.pose[i] = self.reduced_step(b);
                add(
                    lin.h_pose[i].diagonal().as_slice(),
                    lin.g_pose[i].as_slice(),
                    step.pose[i].as_slice(),
                );
            }
        }
        step.point.clear();
        step.point.resize(p.points.len(), Vector3::zeros());
        let (start, entries) = &self.point_obs;
        for x in 0..p.points.len() {
            if !self.point_used[x] {
                continue;
            }
            let mut r = -lin.g_point[x];
            for &(k, _) in &entries[start[x]..start[x + 1]] {
                let pose = p.point_observations[k].pose;
                r -= lin.w_point_obs[k].transpose() * step.pose[pose];
            }
            step.point[x] = self.point_inverse[x] * r;
            add(
                landmark_scale(&lin.h_point[x]).as_slice(),
                lin.g_point[x].as_slice(),
                step.point[x].as_slice(),
            );
        }
        step.plane.clear();
        step.plane.resize(p.planes.len(), Vector3::zeros());
        let (start, entries) = &self.plane_obs;
        for q in 0..p.planes.len() {
            if !self.plane_used[q] {
                continue;
            }
            if self.plane_block[q] != NONE {
                step.plane[q] = self
                    .reduced_step(self.plane_block[q])
                    .fixed_rows::<3>(0)
                    .into();
            } else {
                let mut r = -lin.g_plane[q];
                for &(k, _) in &entries[start[q]..start[q + 1]] {
                    let pose = p.plane_observations[k].pose;
                    r -= lin.w_plane_obs[k].transpose() * step.pose[pose];
                }
                step.plane[q] = self.plane_inverse[q] * r;
            }
            add(
                landmark_scale(&lin.h_plane[q]).as_slice(),
                lin.g_plane[q].as_slice(),
                step.plane[q].as_slice(),
            );
        }
        step.line.clear();
        step.line.resize(p.lines.len(), Vector6::zeros());
        let (start, entries) = &self.line_obs;
        for l in 0..p.lines.len() {
            if !self.line_used[l] {
                continue;
            }
            if self.line_block[l] != NONE {
                step.line[l] = self.reduced_step(self.line_block[l]);
            } else {
                let mut r = -lin.g_line[l];
                for &(k, _) in &entries[start[l]..start[l + 1]] {
                    let pose = p.line_observations[k].pose;
                    r -= lin.w_line_obs[k].transpose() * step.pose[pose];
                }
                step.line[l] = self.line_inverse[l] * r;
            }
            add(
                landmark_scale(&lin.h_line[l]).as_slice(),
                lin.g_line[l].as_slice(),
                step.line[l].as_slice(),
            );
        }
        predicted
    }
}

/// The linearisation of one kind of 3-dof landmark (points or planes) that the Schur
/// complement eliminates: which are used, their observations by pose, their own blocks
/// `h`, `g` and the pose-landmark blocks `w_obs`.
struct Landmarks3<'a> {
    used: &'a [bool],
    obs: &'a ObsLists,
    h: &'a [Matrix3<f64>],
    g: &'a [nalgebra::Vector3<f64>],
    w_obs: &'a [Matrix6x3<f64>],
}

/// The reduced camera system the elimination writes into (right-hand side and the
/// pose-pair blocks), with its scratch row.
struct SchurTarget<'a> {
    scratch: &'a mut Vec<Matrix6x3<f64>>,
    rhs: &'a mut [f64],
    slot_values: &'a mut [Matrix6<f64>],
}
