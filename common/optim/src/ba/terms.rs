//! Evaluation of every BA term at an estimate: chi-square for the outlier checks,
//! robust cost for LM step acceptance, and the linearisation into the normal
//! equations' blocks.

use super::config::BaConfig;
use super::normal::Linearization;
use super::problem::{BaPointObservation, BaProblem};
use crate::residuals::{
    LineReprojection, ManhattanAxis, ParallelLines, ParallelPlanes, PerpendicularLines,
    PerpendicularPlanes, PlaneAxis, PointReprojection, StereoPointReprojection,
};
use crate::robust::{CHI2_1DOF_95, CHI2_2DOF_95, Huber};
use nalgebra::{Isometry3, Matrix6, Matrix6x3, SMatrix, SVector, Vector3, Vector4};

/// The current values of all variables.
#[derive(Clone, Debug, Default)]
pub(crate) struct Values {
    pub(crate) poses: Vec<Isometry3<f64>>,
    pub(crate) points: Vec<Vector3<f64>>,
    pub(crate) lines: Vec<[Vector3<f64>; 2]>,
    pub(crate) planes: Vec<(Vector3<f64>, f64)>,
}

impl Values {
    pub(crate) fn copy_from_problem(&mut self, problem: &BaProblem) {
        self.poses.clear();
        self.poses
            .extend(problem.poses.iter().map(|p| p.camera_from_world));
        self.points.clone_from(&problem.points);
        self.lines.clone_from(&problem.lines);
        self.planes.clone_from(&problem.planes);
    }
}

/// Per-term activity (inlier) flags, in the order of the problem's lists.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BaFlags {
    /// One per [`BaProblem::point_observations`].
    pub point_observations: Vec<bool>,
    /// One per [`BaProblem::line_observations`].
    pub line_observations: Vec<bool>,
    /// One per [`BaProblem::parallel`] pair.
    pub parallel: Vec<bool>,
    /// One per [`BaProblem::perpendicular`] pair.
    pub perpendicular: Vec<bool>,
    /// One per [`BaProblem::manhattan`] association.
    pub manhattan: Vec<bool>,
    /// One per [`BaProblem::plane_observations`].
    pub plane_observations: Vec<bool>,
    /// One per [`BaProblem::plane_parallel`] pair.
    pub plane_parallel: Vec<bool>,
    /// One per [`BaProblem::plane_perpendicular`] pair.
    pub plane_perpendicular: Vec<bool>,
    /// One per [`BaProblem::plane_axes`] association.
    pub plane_axes: Vec<bool>,
}

impl BaFlags {
    pub(crate) fn reset(&mut self, problem: &BaProblem) {
        let reset = |v: &mut Vec<bool>, n: usize| {
            v.clear();
            v.resize(n, true);
        };
        reset(
            &mut self.point_observations,
            problem.point_observations.len(),
        );
        reset(&mut self.line_observations, problem.line_observations.len());
        reset(&mut self.parallel, problem.parallel.len());
        reset(&mut self.perpendicular, problem.perpendicular.len());
        reset(&mut self.manhattan, problem.manhattan.len());
        reset(
            &mut self.plane_observations,
            problem.plane_observations.len(),
        );
        reset(&mut self.plane_parallel, problem.plane_parallel.len());
        reset(
            &mut self.plane_perpendicular,
            problem.plane_perpendicular.len(),
        );
        reset(&mut self.plane_axes, problem.plane_axes.len());
    }
}

/// The problem's terms with their weights and kernels.
pub(crate) struct Terms<'a> {
    pub(crate) problem: &'a BaProblem,
    config: &'a BaConfig,
    point_huber: Huber,
    point_depth_huber: Huber,
    line_huber: Huber,
    parallel_huber: Huber,
    perpendicular_huber: Huber,
    manhattan_huber: Huber,
    plane_huber: Huber,
    /// Information of the plane structural terms (0: off).
    plane_structure_weight: f64,
    /// Kernel of a parallel plane pair or a plane-axis term (2 dof).
    plane_two_dof_huber: Huber,
    /// Kernel of a perpendicular plane pair (1 dof).
    plane_one_dof_huber: Huber,
}

/// Square roots of a plane observation's information per error row (normal x3, offset).
fn plane_weights(o: &super::problem::BaPlaneObservation) -> Vector4<f64> {
    let (wn, wd) = (o.inv_sigma2_normal.sqrt(), o.inv_sigma2_offset.sqrt());
    Vector4::new(wn, wn, wn, wd)
}

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

impl<'a> Terms<'a> {
    pub(crate) fn new(problem: &'a BaProblem, config: &'a BaConfig) -> Self {
        Self {
            problem,
            config,
            point_huber: Huber::from_chi2(config.point_chi2),
            point_depth_huber: Huber::from_chi2(config.point_depth_chi2),
            line_huber: Huber::from_chi2(config.line_chi2),
            parallel_huber: Huber::from_chi2(config.parallel_chi2),
            perpendicular_huber: Huber::from_chi2(config.perpendicular_chi2),
            manhattan_huber: Huber::from_chi2(config.manhattan_chi2),
            plane_huber: Huber::from_chi2(config.plane_chi2),
            plane_structure_weight: config.plane_structure_information(),
            plane_two_dof_huber: Huber::from_chi2(CHI2_2DOF_95),
            plane_one_dof_huber: Huber::from_chi2(CHI2_1DOF_95),
        }
    }

    /// True when parallel plane pair `k` takes part (weight on and flagged inlier).
    pub(crate) fn plane_parallel_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.plane_structure_weight > 0.0 && flags.plane_parallel[k]
    }

    /// True when perpendicular plane pair `k` takes part.
    pub(crate) fn plane_perpendicular_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.plane_structure_weight > 0.0 && flags.plane_perpendicular[k]
    }

    /// True when plane-axis association `k` takes part.
    pub(crate) fn plane_axis_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.plane_structure_weight > 0.0 && flags.plane_axes[k]
    }

    /// True when parallel pair `k` takes part (weight on and flagged inlier).
    pub(crate) fn parallel_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.config.parallel_weight > 0.0 && flags.parallel[k]
    }

    /// True when perpendicular pair `k` takes part.
    pub(crate) fn perpendicular_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.config.perpendicular_weight > 0.0 && flags.perpendicular[k]
    }

    /// True when Manhattan association `k` takes part.
    pub(crate) fn manhattan_active(&self, flags: &BaFlags, k: usize) -> bool {
        self.config.manhattan_weight > 0.0 && flags.manhattan[k]
    }

    fn point_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let o = &self.problem.point_observations[k];
        let (camera, pose, point) = (&self.problem.camera, &v.poses[o.pose], &v.points[o.point]);
        let e2 = if o.depth > 0.0 {
            self.stereo(o).error(camera, pose, point)?.norm_squared()
        } else {
            PointReprojection { uv: o.uv }
                .error(camera, pose, point)?
                .norm_squared()
        };
        Some(o.inv_sigma2 * e2)
    }

    fn stereo(&self, o: &BaPointObservation) -> StereoPointReprojection {
        let (bf, sigma) = (self.config.bf, self.config.inverse_depth_sigma);
        let scale = StereoPointReprojection::disparity_scale(o.inv_sigma2, bf, sigma);
        StereoPointReprojection::from_depth(o.uv, o.depth, bf, scale)
    }

    /// Threshold and kernel of point observation `k` (with or without depth).
    fn point_kind(&self, k: usize) -> (f64, &Huber) {
        if self.problem.point_observations[k].depth > 0.0 {
            (self.config.point_depth_chi2, &self.point_depth_huber)
        } else {
            (self.config.point_chi2, &self.point_huber)
        }
    }

    fn line_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let o = &self.problem.line_observations[k];
        let e = LineReprojection { coeffs: o.coeffs }.error(
            &self.problem.camera,
            &v.poses[o.pose],
            &v.lines[o.line],
        )?;
        Some(o.inv_sigma2 * e.norm_squared())
    }

    fn parallel_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let (i, j) = self.problem.parallel[k];
        if i == j {
            return None;
        }
        let e = ParallelLines.error(&v.lines[i], &v.lines[j])?;
        Some(self.config.parallel_weight * e.norm_squared())
    }

    fn perpendicular_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let (i, j) = self.problem.perpendicular[k];
        if i == j {
            return None;
        }
        let e = PerpendicularLines.error(&v.lines[i], &v.lines[j])?;
        Some(self.config.perpendicular_weight * e * e)
    }

    fn manhattan_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let m = &self.problem.manhattan[k];
        let e = ManhattanAxis { axis: m.axis }.error(&v.lines[m.line])?;
        Some(self.config.manhattan_weight * e.norm_squared())
    }

    fn plane_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let o = &self.problem.plane_observations[k];
        let (n, d) = &v.planes[o.plane];
        let e = o.measured.error(&v.poses[o.pose], n, *d);
        let s = plane_weights(o).component_mul(&e).norm_squared();
        s.is_finite().then_some(s)
    }

    fn plane_parallel_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let (i, j) = self.problem.plane_parallel[k];
        let e = ParallelPlanes.error(&v.planes[i].0, &v.planes[j].0);
        (i != j).then(|| self.plane_structure_weight * e.norm_squared())
    }

    fn plane_perpendicular_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let (i, j) = self.problem.plane_perpendicular[k];
        let e = PerpendicularPlanes.error(&v.planes[i].0, &v.planes[j].0);
        (i != j).then_some(self.plane_structure_weight * e * e)
    }

    fn plane_axis_chi2(&self, v: &Values, k: usize) -> Option<f64> {
        let m = &self.problem.plane_axes[k];
        let e = PlaneAxis { axis: m.axis }.error(&v.planes[m.plane].0);
        Some(self.plane_structure_weight * e.norm_squared())
    }

    /// Cost of the line depth priors at `v` (plain least squares: a prior is never an
    /// outlier).
    fn line_prior_cost(&self, v: &Values) -> f64 {
        let mut cost = 0.0;
        for prior in &self.problem.line_priors {
            for (k, measured) in prior.endpoints.iter().enumerate() {
                cost += prior.information[k] * (v.lines[prior.line][k] - measured).norm_squared();
            }
        }
        cost
    }

    /// Flags every term by its chi-square at `v`: invalid (behind the camera,
    /// degenerate line, non-positive information) or above its threshold = outlier.
    pub(crate) fn classify(&self, v: &Values, flags: &mut BaFlags) {
        let inlier = |s: Option<f64>, threshold: f64| s.is_some_and(|s| s <= threshold);
        let p = self.problem;
        for (k, f) in flags.point_observations.iter_mut().enumerate() {
            *f = p.point_observations[k].inv_sigma2 > 0.0
                && inlier(self.point_chi2(v, k), self.point_kind(k).0);
        }
        for (k, f) in flags.line_observations.iter_mut().enumerate() {
            *f = p.line_observations[k].inv_sigma2 > 0.0
                && inlier(self.line_chi2(v, k), self.config.line_chi2);
        }
        for (k, f) in flags.parallel.iter_mut().enumerate() {
            *f = inlier(self.parallel_chi2(v, k), self.config.parallel_chi2);
        }
        for (k, f) in flags.perpendicular.iter_mut().enumerate() {
            *f = inlier(
                self.perpendicular_chi2(v, k),
                self.config.perpendicular_chi2,
            );
        }
        for (k, f) in flags.manhattan.iter_mut().enumerate() {
            *f = inlier(self.manhattan_chi2(v, k), self.config.manhattan_chi2);
        }
        for (k, f) in flags.plane_observations.iter_mut().enumerate() {
            *f = inlier(self.plane_chi2(v, k), self.config.plane_chi2);
        }
        for (k, f) in flags.plane_parallel.iter_mut().enumerate() {
            *f = inlier(self.plane_parallel_chi2(v, k), CHI2_2DOF_95);
        }
        for (k, f) in flags.plane_perpendicular.iter_mut().enumerate() {
            *f = inlier(self.plane_perpendicular_chi2(v, k), CHI2_1DOF_95);
        }
        for (k, f) in flags.plane_axes.iter_mut().enumerate() {
            *f = inlier(self.plane_axis_chi2(v, k), CHI2_2DOF_95);
        }
    }

    /// Flags only the terms that cannot be evaluated at `v` (the start of the first
    /// pass, when every valid term is an inlier).
    pub(crate) fn mark_invalid(&self, v: &Values, flags: &mut BaFlags) {
        let p = self.problem;
        for (k, f) in flags.point_observations.iter_mut().enumerate() {
            *f = p.point_observations[k].inv_sigma2 > 0.0 && self.point_chi2(v, k).is_some();
        }
        for (k, f) in flags.line_observations.iter_mut().enumerate() {
            *f = p.line_observations[k].inv_sigma2 > 0.0 && self.line_chi2(v, k).is_some();
        }
        for (k, f) in flags.parallel.iter_mut().enumerate() {
            *f = self.parallel_chi2(v, k).is_some();
        }
        for (k, f) in flags.perpendicular.iter_mut().enumerate() {
            *f = self.perpendicular_chi2(v, k).is_some();
        }
        for (k, f) in flags.manhattan.iter_mut().enumerate() {
            *f = self.manhattan_chi2(v, k).is_some();
        }
        for (k, f) in flags.plane_observations.iter_mut().enumerate() {
            *f = self.plane_chi2(v, k).is_some();
        }
        for (k, f) in flags.plane_parallel.iter_mut().enumerate() {
            *f = self.plane_parallel_chi2(v, k).is_some();
        }
        for (k, f) in flags.plane_perpendicular.iter_mut().enumerate() {
            *f = self.plane_perpendicular_chi2(v, k).is_some();
        }
        for (k, f) in flags.plane_axes.iter_mut().enumerate() {
            *f = self.plane_axis_chi2(v, k).is_some();
        }
    }

    /// Robust cost of the active terms at `v`. With `strict`, `None` when one of them
    /// cannot be evaluated there (the LM step that led there is rejected); otherwise
    /// such terms are skipped.
    pub(crate) fn cost(&self, v: &Values, flags: &BaFlags, strict: bool) -> Option<f64> {
        let mut cost = 0.0;
        let mut add = |s: Option<f64>, huber: &Huber| match s {
            Some(s) => {
                cost += huber.cost(s);
                true
            }
            None => !strict,
        };
        let mut ok = true;
        for k in (0..flags.point_observations.len()).filter(|&k| flags.point_observations[k]) {
            ok &= add(self.point_chi2(v, k), self.point_kind(k).1);
        }
        for k in (0..flags.line_observations.len()).filter(|&k| flags.line_observations[k]) {
            ok &= add(self.line_chi2(v, k), &self.line_huber);
        }
        for k in (0..flags.parallel.len()).filter(|&k| self.parallel_active(flags, k)) {
            ok &= add(self.parallel_chi2(v, k), &self.parallel_huber);
        }
        for k in (0..flags.perpendicular.len()).filter(|&k| self.perpendicular_active(flags, k)) {
            ok &= add(self.perpendicular_chi2(v, k), &self.perpendicular_huber);
        }
        for k in (0..flags.manhattan.len()).filter(|&k| self.manhattan_active(flags, k)) {
            ok &= add(self.manhattan_chi2(v, k), &self.manhattan_huber);
        }
        for k in (0..flags.plane_observations.len()).filter(|&k| flags.plane_observations[k]) {
            ok &= add(self.plane_chi2(v, k), &self.plane_huber);
        }
        for k in (0..flags.plane_parallel.len()).filter(|&k| self.plane_parallel_active(flags, k)) {
            ok &= add(self.plane_parallel_chi2(v, k), &self.plane_two_dof_huber);
        }
        let perpendicular = 0..flags.plane_perpendicular.len();
        for k in perpendicular.filter(|&k| self.plane_perpendicular_active(flags, k)) {
            ok &= add(
                self.plane_perpendicular_chi2(v, k),
                &self.plane_one_dof_huber,
            );
        }
        for k in (0..flags.plane_axes.len()).filter(|&k| self.plane_axis_active(flags, k)) {
            ok &= add(self.plane_axis_chi2(v, k), &self.plane_two_dof_huber);
        }
        cost += self.line_prior_cost(v);
        (ok && cost.is_finite()).then_some(cost)
    }

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ba::problem::{BaLinePrior, BaPose};
    use gfs_core::camera::PinholeCamera;

    /// The line prior's blocks are the Gauss-Newton form of its cost: `g` is half the
    /// cost's gradient and `H` the identity times the information, checked against
    /// central differences.
    #[test]
    fn line_prior_blocks_match_numeric_differences() {
        let mut problem = BaProblem::new(PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480));
        problem.poses.push(BaPose {
            camera_from_world: Isometry3::identity(),
            fixed: true,
        });
        problem
            .lines
            .push([Vector3::new(0.1, -0.2, 2.0), Vector3::new(0.4, 0.3, 2.5)]);
        problem.line_priors.push(BaLinePrior {
            line: 0,
            endpoints: [
                Vector3::new(0.12, -0.21, 2.1),
                Vector3::new(0.38, 0.33, 2.4),
            ],
            information: [400.0, 100.0],
        });
        let config = BaConfig::default();
        let terms = Terms::new(&problem, &config);
        let mut values = Values::default();
        values.copy_from_problem(&problem);
        let mut flags = BaFlags::default();
        flags.reset(&problem);
        let mut lin = Linearization::default();
        lin.resize(&problem);
        terms.linearize(&values, &flags, &mut lin);
        let cost = |v: &Values| terms.cost(v, &flags, true).expect("valid");
        let h = 1e-6;
        for k in 0..6 {
            let (end, axis) = (k / 3, k % 3);
            let (mut plus, mut minus) = (values.clone(), values.clone());
            plus.lines[0][end][axis] += h;
            minus.lines[0][end][axis] -= h;
            let half_gradient = (cost(&plus) - cost(&minus)) / (4.0 * h);
            assert!((lin.g_line[0][k] - half_gradient).abs() < 1e-6, "g[{k}]");
            let information = problem.line_priors[0].information[end];
            assert!((lin.h_line[0][(k, k)] - information).abs() < 1e-9, "H[{k}]");
        }
        assert!((lin.cost - cost(&values)).abs() < 1e-9);
    }
}
