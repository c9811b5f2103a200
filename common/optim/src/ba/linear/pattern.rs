//! The block pattern of the reduced system for one pass's active terms: which
//! variables are eliminated and which kept, the slot of every block the Schur
//! complement touches, the observation lists per landmark, and the symbolic analysis.

use super::{NONE, ObsLists, ReducedSystem};
use crate::ba::BaError;
use crate::ba::terms::{BaFlags, Terms};
use crate::block_cholesky::BlockCholesky;

/// Builds CSR lists of (observation, pose block) per landmark.
fn build_lists(
    count: usize,
    observations: impl Iterator<Item = (usize, usize, usize)> + Clone,
    lists: &mut ObsLists,
) {
    let (start, entries) = lists;
    start.clear();
    start.resize(count + 1, 0);
    for (_, landmark, _) in observations.clone() {
        start[landmark + 1] += 1;
    }
    for i in 0..count {
        start[i + 1] += start[i];
    }
    entries.clear();
    entries.resize(start[count], (0, 0));
    let mut fill = start.clone();
    for (k, landmark, block) in observations {
        entries[fill[landmark]] = (k, block);
        fill[landmark] += 1;
    }
}

impl ReducedSystem {
    fn slot(&mut self, row: usize, col: usize) -> usize {
        let key = (row.max(col), row.min(col));
        let next = self.slots.len();
        let slot = *self.slot_of.entry(key).or_insert(next);
        if slot == next {
            self.slots.push(key);
        }
        slot
    }

    /// Sets up the block structure and the symbolic factorisation for the active terms.
    ///
    /// # Errors
    /// [`BaError::Solver`] when faer cannot build the pattern or its analysis.
    pub(crate) fn analyse(&mut self, terms: &Terms<'_>, flags: &BaFlags) -> Result<(), BaError> {
        let p = terms.problem;
        self.pose_block.clear();
        let mut blocks = 0;
        for pose in &p.poses {
            self.pose_block.push(if pose.fixed { NONE } else { blocks });
            blocks += usize::from(!pose.fixed);
        }
        let free_poses = blocks;
        self.line_block.clear();
        self.line_block.resize(p.lines.len(), NONE);
        self.line_used.clear();
        self.line_used.resize(p.lines.len(), false);
        self.point_used.clear();
        self.point_used.resize(p.points.len(), false);
        self.plane_used.clear();
        self.plane_used.resize(p.planes.len(), false);
        for (o, _) in p
            .plane_observations
            .iter()
            .zip(&flags.plane_observations)
            .filter(|(_, f)| **f)
        {
            self.plane_used[o.plane] = true;
        }
        for (k, m) in p.plane_axes.iter().enumerate() {
            self.plane_used[m.plane] |= terms.plane_axis_active(flags, k);
        }
        self.plane_block.clear();
        self.plane_block.resize(p.planes.len(), NONE);
        let plane_pairs = p
            .plane_parallel
            .iter()
            .enumerate()
            .filter(|&(k, _)| terms.plane_parallel_active(flags, k))
            .chain(
                p.plane_perpendicular
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| terms.plane_perpendicular_active(flags, k)),
            );
        for (_, &(i, j)) in plane_pairs {
            for q in [i, j] {
                if self.plane_block[q] == NONE {
                    self.plane_block[q] = blocks;
                    blocks += 1;
                }
                self.plane_used[q] = true;
            }
        }
        self.plane_eliminated.clear();
        let eliminated = self
            .plane_used
            .iter()
            .zip(&self.plane_block)
            .map(|(&used, &block)| used && block == NONE);
        self.plane_eliminated.extend(eliminated);
        let pairs = p
            .parallel
            .iter()
            .enumerate()
            .filter(|&(k, _)| terms.parallel_active(flags, k))
            .chain(
                p.perpendicular
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| terms.perpendicular_active(flags, k)),
            );
        for (_, &(i, j)) in pairs {
            for l in [i, j] {
                if self.line_block[l] == NONE {
                    self.line_block[l] = blocks;
                    blocks += 1;
                }
                self.line_used[l] = true;
            }
        }
        self.blocks = blocks;
        for (o, _) in p
            .point_observations
            .iter()
            .zip(&flags.point_observations)
            .filter(|(_, f)| **f)
        {
            self.point_used[o.point] = true;
        }
        for (o, _) in p
            .line_observations
            .iter()
            .zip(&flags.line_observations)
            .filter(|(_, f)| **f)
        {
            self.line_used[o.line] = true;
        }
        for (k, m) in p.manhattan.iter().enumerate() {
            self.line_used[m.line] |= terms.manhattan_active(flags, k);
        }

        let pose_block = &self.pose_block;
        let point_iter = p
            .point_observations
            .iter()
            .enumerate()
            .filter(|&(k, o)| flags.point_observations[k] && pose_block[o.pose] != NONE)
            .map(|(k, o)| (k, o.point, pose_block[o.pose]));
        build_lists(p.points.len(), point_iter, &mut self.point_obs);
        let plane_block = &self.plane_block;
        let plane_iter = p
            .plane_observations
            .iter()
            .enumerate()
            .filter(|&(k, o)| {
                flags.plane_observations[k]
                    && pose_block[o.pose] != NONE
                    && plane_block[o.plane] == NONE
            })
            .map(|(k, o)| (k, o.plane, pose_block[o.pose]));
        build_lists(p.planes.len(), plane_iter, &mut self.plane_obs);
        let line_block = &self.line_block;
        let line_iter = p
            .line_observations
            .iter()
            .enumerate()
            .filter(|&(k, o)| {
                flags.line_observations[k]
                    && pose_block[o.pose] != NONE
                    && line_block[o.line] == NONE
            })
            .map(|(k, o)| (k, o.line, pose_block[o.pose]));
        build_lists(p.lines.len(), line_iter, &mut self.line_obs);

        // Block pattern (lower triangle): all pose pairs (local BA covisibility is close
        // to dense), kept lines' diagonals, their pose couplings and their pairs.
        self.slots.clear();
        self.slot_of.clear();
        for a in 0..free_poses {
            for b in 0..=a {
                self.slot(a, b);
            }
        }
        for l in 0..p.lines.len() {
            if self.line_block[l] != NONE {
                self.slot(self.line_block[l], self.line_block[l]);
            }
        }
        self.line_obs_slot.clear();
        for (k, o) in p.line_observations.iter().enumerate() {
            let (lb, pb) = (self.line_block[o.line], self.pose_block[o.pose]);
            let slot = if flags.line_observations[k] && lb != NONE && pb != NONE {
                self.slot(lb, pb)
            } else {
                NONE
            };
            self.line_obs_slot.push(slot);
        }
        self.parallel_slot.clear();
        for (k, &(i, j)) in p.parallel.iter().enumerate() {
            let slot = if terms.parallel_active(flags, k) {
                self.slot(self.line_block[i], self.line_block[j])
            } else {
                NONE
            };
            self.parallel_slot.push(slot);
        }
        self.perpendicular_slot.clear();
        for (k, &(i, j)) in p.perpendicular.iter().enumerate() {
            let slot = if terms.perpendicular_active(flags, k) {
                self.slot(self.line_block[i], self.line_block[j])
            } else {
                NONE
            };
            self.perpendicular_slot.push(slot);
        }

        self.analyse_kept_planes(terms, flags);

        // The second pass, and often the next keyframe's BA, keeps the pattern: its
        // symbolic analysis (the ordering) is then still valid.
        let kept = (self.factorization.as_ref()).is_some_and(|f| f.is_for(&self.slots));
        if !kept {
            self.factorization =
                BlockCholesky::analyse(self.blocks, &self.slots).map_err(|reason| {
                    BaError::Solver {
                        dimension: 6 * self.blocks,
                        reason,
                    }
                })?;
        }
        Ok(())
    }

    /// Slots of the kept planes: their diagonals, the poses observing them, their pairs.
    fn analyse_kept_planes(&mut self, terms: &Terms<'_>, flags: &BaFlags) {
        let p = terms.problem;
        for q in 0..p.planes.len() {
            if self.plane_block[q] != NONE {
                self.slot(self.plane_block[q], self.plane_block[q]);
            }
        }
        self.plane_obs_slot.clear();
        for (k, o) in p.plane_observations.iter().enumerate() {
            let (qb, pb) = (self.plane_block[o.plane], self.pose_block[o.pose]);
            let slot = if flags.plane_observations[k] && qb != NONE && pb != NONE {
                self.slot(qb, pb)
            } else {
                NONE
            };
            self.plane_obs_slot.push(slot);
        }
        self.plane_parallel_slot.clear();
        for (k, &(i, j)) in p.plane_parallel.iter().enumerate() {
            let slot = if terms.plane_parallel_active(flags, k) && i != j {
                self.slot(self.plane_block[i], self.plane_block[j])
            } else {
                NONE
            };
            self.plane_parallel_slot.push(slot);
        }
        self.plane_perpendicular_slot.clear();
        for (k, &(i, j)) in p.plane_perpendicular.iter().enumerate() {
            let slot = if terms.plane_perpendicular_active(flags, k) && i != j {
                self.slot(self.plane_block[i], self.plane_block[j])
            } else {
                NONE
            };
            self.plane_perpendicular_slot.push(slot);
        }
    }
}
