//! Evaluation of every BA term at an estimate: chi-square for the outlier checks,
//! robust cost for LM step acceptance, and the linearisation into the normal
//! equations' blocks.

use super::config::BaConfig;

use super::problem::{BaPointObservation, BaProblem};
use crate::residuals::{
    LineReprojection, ManhattanAxis, ParallelLines, ParallelPlanes, PerpendicularLines,
    PerpendicularPlanes, PlaneAxis, PointReprojection, StereoPointReprojection,
};
use crate::robust::{CHI2_1DOF_95, CHI2_2DOF_95, Huber};
use nalgebra::{Isometry3, Vector3, Vector4};

mod linearize;

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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ba::normal::Linearization;
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
