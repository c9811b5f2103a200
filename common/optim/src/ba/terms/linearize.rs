//! The linearisation of every BA term at an estimate into the blocks of the normal
//! equations (`J^T w J`, `J^T w e` per variable and per pose-landmark pair).

use super::{BaFlags, Terms, Values, plane_weights};
use crate::ba::normal::Linearization;
use crate::residuals::{
    LineReprojection, ManhattanAxis, ParallelLines, ParallelPlanes, PerpendicularLines,
    PerpendicularPlanes, PlaneAxis, PointReprojection,
};
use nalgebra::{Matrix6, Matrix6x3, SMatrix, SVector};

/// Adds `J^T w J` and `J^T w e` of a residual of one variable to its blocks.
#[inline]
fn add_block<const R: usize, const C: usize>(
    h: &mut SMatrix<f64, C, C>,
    g: &mut SVector<f64, C>,
    j: &SMatrix<f64, R, C>,
    e: &SVector<f64, R>,
    w: f64,
) {
    let jt_w = j.transpose() * w;
    *h += jt_w * j;
    *g += jt_w * e;
}

impl Terms<'_> {
    /// Linearises every active term at `v` into `lin` (blocks zeroed first; a pose-landmark
    /// block is written for every active observation, so it needs no zeroing).
    pub(crate) fn linearize(&self, v: &Values, flags: &BaFlags, lin: &mut Linearization) {
        lin.clear();
        let p = self.problem;
        let camera = &p.camera;
        for (k, o) in p.point_observations.iter().enumerate() {
            if !flags.point_observations[k] {
                continue;
            }
            let (pose, point) = (&v.poses[o.pose], &v.points[o.point]);
            let added = if o.depth > 0.0 {
                (self.stereo(o).linearize(camera, pose, point))
                    .map(|l| self.add_point(lin, k, &l.d_pose, &l.d_point, &l.error))
            } else {
                (PointReprojection { uv: o.uv }.linearize(camera, pose, point))
                    .map(|l| self.add_point(lin, k, &l.d_pose, &l.d_point, &l.error))
            };
            if added.is_none() {
                lin.w_point_obs[k] = Matrix6x3::zeros();
            }
        }
        for prior in &p.line_priors {
            let line = &v.lines[prior.line];
            for (k, measured) in prior.endpoints.iter().enumerate() {
                let w = prior.information[k];
                let e = line[k] - measured;
                lin.cost += w * e.norm_squared();
                for r in 0..3 {
                    lin.h_line[prior.line][(3 * k + r, 3 * k + r)] += w;
                    lin.g_line[prior.line][3 * k + r] += w * e[r];
                }
            }
        }
        for (k, o) in p.line_observations.iter().enumerate() {
            if !flags.line_observations[k] {
                continue;
            }
            let r = LineReprojection { coeffs: o.coeffs };
            let Some(l) = r.linearize(camera, &v.poses[o.pose], &v.lines[o.line]) else {
                lin.w_line_obs[k] = Matrix6::zeros();
                continue;
            };
            let s = o.inv_sigma2 * l.error.norm_squared();
            let w = o.inv_sigma2 * self.line_huber.weight(s);
            lin.cost += self.line_huber.cost(s);
            add_block(
                &mut lin.h_line[o.line],
                &mut lin.g_line[o.line],
                &l.d_line,
                &l.error,
                w,
            );
            if !p.poses[o.pose].fixed {
                add_block(
                    &mut lin.h_pose[o.pose],
                    &mut lin.g_pose[o.pose],
                    &l.d_pose,
                    &l.error,
                    w,
                );
                lin.w_line_obs[k] = l.d_pose.transpose() * w * l.d_line;
            }
        }
        for (k, &(i, j)) in p.parallel.iter().enumerate() {
            if !self.parallel_active(flags, k) {
                continue;
            }
            let Some(l) = ParallelLines.linearize(&v.lines[i], &v.lines[j]) else {
                continue;
            };
            let s = self.config.parallel_weight * l.error.norm_squared();
            let w = self.config.parallel_weight * self.parallel_huber.weight(s);
            lin.cost += self.parallel_huber.cost(s);
            add_block(
                &mut lin.h_line[i],
                &mut lin.g_line[i],
                &l.d_first,
                &l.error,
                w,
            );
            add_block(
                &mut lin.h_line[j],
                &mut lin.g_line[j],
                &l.d_second,
                &l.error,
                w,
            );
            lin.h_parallel[k] = l.d_first.transpose() * w * l.d_second;
        }
        for (k, &(i, j)) in p.perpendicular.iter().enumerate() {
            if !self.perpendicular_active(flags, k) {
                continue;
            }
            let Some(l) = PerpendicularLines.linearize(&v.lines[i], &v.lines[j]) else {
                continue;
            };
            let s = self.config.perpendicular_weight * l.error * l.error;
            let w = self.config.perpendicular_weight * self.perpendicular_huber.weight(s);
            let e = SVector::<f64, 1>::new(l.error);
            lin.cost += self.perpendicular_huber.cost(s);
            add_block(&mut lin.h_line[i], &mut lin.g_line[i], &l.d_first, &e, w);
            add_block(&mut lin.h_line[j], &mut lin.g_line[j], &l.d_second, &e, w);
            lin.h_perpendicular[k] = l.d_first.transpose() * w * l.d_second;
        }
        for (k, m) in p.manhattan.iter().enumerate() {
            if !self.manhattan_active(flags, k) {
                continue;
            }
            let Some(l) = (ManhattanAxis { axis: m.axis }).linearize(&v.lines[m.line]) else {
                continue;
            };
            let s = self.config.manhattan_weight * l.error.norm_squared();
            let w = self.config.manhattan_weight * self.manhattan_huber.weight(s);
            lin.cost += self.manhattan_huber.cost(s);
            add_block(
                &mut lin.h_line[m.line],
                &mut lin.g_line[m.line],
                &l.d_line,
                &l.error,
                w,
            );
        }
        for (k, o) in p.plane_observations.iter().enumerate() {
            if !flags.plane_observations[k] {
                continue;
            }
            let (n, d) = &v.planes[o.plane];
            let l = o.measured.linearize(&v.poses[o.pose], n, *d);
            // Whitened rows: the normal's and the offset's weights differ.
            let w_rows = plane_weights(o);
            let e = w_rows.component_mul(&l.error);
            let d_pose = SMatrix::<f64, 4, 6>::from_fn(|r, c| w_rows[r] * l.d_pose[(r, c)]);
            let d_plane = SMatrix::<f64, 4, 3>::from_fn(|r, c| w_rows[r] * l.d_plane[(r, c)]);
            let s = e.norm_squared();
            let w = self.plane_huber.weight(s);
            lin.cost += self.plane_huber.cost(s);
            add_block(
                &mut lin.h_plane[o.plane],
                &mut lin.g_plane[o.plane],
                &d_plane,
                &e,
                w,
            );
            if !p.poses[o.pose].fixed {
                add_block(
                    &mut lin.h_pose[o.pose],
                    &mut lin.g_pose[o.pose],
                    &d_pose,
                    &e,
                    w,
                );
                lin.w_plane_obs[k] = d_pose.transpose() * w * d_plane;
            }
        }
        self.linearize_plane_structure(v, flags, lin);
    }

    /// Linearises the active parallel / perpendicular plane pairs and plane-axis terms.
    fn linearize_plane_structure(&self, v: &Values, flags: &BaFlags, lin: &mut Linearization) {
        let p = self.problem;
        let weight = self.plane_structure_weight;
        for (k, &(i, j)) in p.plane_parallel.iter().enumerate() {
            if !self.plane_parallel_active(flags, k) || i == j {
                continue;
            }
            let l = ParallelPlanes.linearize(&v.planes[i].0, &v.planes[j].0);
            let s = weight * l.error.norm_squared();
            let w = weight * self.plane_two_dof_huber.weight(s);
            lin.cost += self.plane_two_dof_huber.cost(s);
            let (hi, gi) = (&mut lin.h_plane[i], &mut lin.g_plane[i]);
            add_block(hi, gi, &l.d_first, &l.error, w);
            let (hj, gj) = (&mut lin.h_plane[j], &mut lin.g_plane[j]);
            add_block(hj, gj, &l.d_second, &l.error, w);
            lin.h_plane_parallel[k] = l.d_first.transpose() * w * l.d_second;
        }
        for (k, &(i, j)) in p.plane_perpendicular.iter().enumerate() {
            if !self.plane_perpendicular_active(flags, k) || i == j {
                continue;
            }
            let l = PerpendicularPlanes.linearize(&v.planes[i].0, &v.planes[j].0);
            let s = weight * l.error * l.error;
            let w = weight * self.plane_one_dof_huber.weight(s);
            let e = SVector::<f64, 1>::new(l.error);
            lin.cost += self.plane_one_dof_huber.cost(s);
            add_block(&mut lin.h_plane[i], &mut lin.g_plane[i], &l.d_first, &e, w);
            add_block(&mut lin.h_plane[j], &mut lin.g_plane[j], &l.d_second, &e, w);
            lin.h_plane_perpendicular[k] = l.d_first.transpose() * w * l.d_second;
        }
        for (k, m) in p.plane_axes.iter().enumerate() {
            if !self.plane_axis_active(flags, k) {
                continue;
            }
            let l = (PlaneAxis { axis: m.axis }).linearize(&v.planes[m.plane].0);
            let s = weight * l.error.norm_squared();
            let w = weight * self.plane_two_dof_huber.weight(s);
            lin.cost += self.plane_two_dof_huber.cost(s);
            let (h, g) = (&mut lin.h_plane[m.plane], &mut lin.g_plane[m.plane]);
            add_block(h, g, &l.d_plane, &l.error, w);
        }
    }

    /// Adds point observation `k` (2D or RGB-D) to the blocks.
    fn add_point<const R: usize>(
        &self,
        lin: &mut Linearization,
        k: usize,
        d_pose: &SMatrix<f64, R, 6>,
        d_point: &SMatrix<f64, R, 3>,
        error: &SVector<f64, R>,
    ) {
        let o = &self.problem.point_observations[k];
        let huber = self.point_kind(k).1;
        let s = o.inv_sigma2 * error.norm_squared();
        let w = o.inv_sigma2 * huber.weight(s);
        lin.cost += huber.cost(s);
        add_block(
            &mut lin.h_point[o.point],
            &mut lin.g_point[o.point],
            d_point,
            error,
            w,
        );
        if !self.problem.poses[o.pose].fixed {
            add_block(
                &mut lin.h_pose[o.pose],
                &mut lin.g_pose[o.pose],
                d_pose,
                error,
                w,
            );
            lin.w_point_obs[k] = d_pose.transpose() * w * d_point;
        }
    }
}
