//! Manhattan axes (MA) of a frame from its plane normals and 3D line directions
//! (paper Sec. III-A, "Spatial feature", after Kim et al. 2018), kept consistent in
//! identity and sign from frame to frame.
//!
//! Model: the scene's dominant directions are three orthogonal axes, the columns of a
//! rotation `camera_from_manhattan`. Every plane normal and line direction is an
//! unsigned unit vector with a weight; it supports the axis it is within
//! `ma_inlier_angle_deg` of. Steps per frame:
//! 1. hypotheses: every near-orthogonal pair among the heaviest directions (third axis
//!    by cross product), plus the previous frame's axes moved by the predicted rotation;
//! 2. score: the weighted soft inlier count of all directions; the best pair and the
//!    prediction are refined and the better one kept (the prediction wins ties, so a
//!    frame does not jump between equally good structures);
//! 3. refine: sum the sign-aligned inliers of each axis into the columns of a matrix
//!    and project it onto SO(3) (polar decomposition by SVD), three rounds;
//! 4. label: permute and flip the axes to match the predicted previous axes by |dot|.

use crate::axes::{ManhattanAxes, closest_rotation, match_to};
use crate::config::PlaneConfig;
use crate::error::PlaneError;
use crate::extractor::Plane;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// One weighted, unsigned direction of the frame.
#[derive(Clone, Copy, Debug)]
struct Direction {
    dir: Vector3<f64>,
    weight: f64,
    /// A plane normal (already a large region, so one is enough to observe an axis).
    plane: bool,
}

/// Directions tried in pairs as hypotheses: the heaviest ones (66 pairs at most).
const HYPOTHESIS_DIRECTIONS: usize = 12;
/// Refinement rounds (inlier sets are stable after two on the box-room fixtures).
const REFINE_ROUNDS: usize = 3;
/// Weight of the hypothesis itself in the refinement, relative to the frame's vote:
/// it only fixes the axes that no direction observes.
const PRIOR_WEIGHT: f64 = 1e-3;

/// Estimates the Manhattan axes of successive frames; keeps the previous frame's axes
/// so that axis `i` stays the same world direction with the same sign.
#[derive(Clone, Debug)]
pub struct ManhattanEstimator {
    cos_inlier: f64,
    sin_orthogonal: f64,
    plane_share: f64,
    min_axis_support: f64,
    min_support: f64,
    directions: Vec<Direction>,
    order: Vec<usize>,
    previous: Option<Rotation3<f64>>,
}

impl ManhattanEstimator {
    /// An estimator with the `ma_*` parameters of `config` and no history.
    ///
    /// # Errors
    /// [`PlaneError::InvalidConfig`] naming the first invalid field.
    pub fn new(config: &PlaneConfig) -> Result<Self, PlaneError> {
        config.validate()?;
        Ok(Self {
            cos_inlier: f64::from(config.ma_inlier_angle_deg).to_radians().cos(),
            sin_orthogonal: f64::from(config.ma_orthogonality_deg).to_radians().sin(),
            plane_share: config.ma_plane_share.into(),
            min_axis_support: config.ma_min_axis_support.into(),
            min_support: config.ma_min_support.into(),
            directions: Vec::new(),
            order: Vec::new(),
            previous: None,
        })
    }

    /// Forgets the previous frame's axes (the next frame labels its axes afresh).
    pub fn reset(&mut self) {
        self.previous = None;
    }

    /// Resumes with the previous axes of a checkpoint (see [`Self::previous`]).
    pub fn restore(&mut self, previous: Option<Rotation3<f64>>) {
        self.previous = previous;
    }

    /// The axes of the last frame that had them, moved by the predicted rotations of
    /// the frames without MA since; `None` before the first MA or after [`Self::reset`].
    pub fn previous(&self) -> Option<&Rotation3<f64>> {
        self.previous.as_ref()
    }

    /// The Manhattan axes of one frame, or `None` when the frame has no dominant
    /// orthogonal structure (no direction, or less than `ma_min_support` of the vote on
    /// the best axes).
    ///
    /// - `planes`: this frame's planes, weighted by pixels;
    /// - `line_dirs`, `line_weights`: 3D line directions in the camera frame (any
    ///   length, any sign) and their weights (e.g. length in metres), paired up to the
    ///   shorter slice; zero, negative or non-finite entries are skipped;
    /// - `predicted_rotation`: `current_from_previous`, the rotation taking a vector in
    ///   the previous camera frame to this one (`R_wc_k^T * R_wc_{k-1}`), identity when
    ///   `None` (or not finite). It carries the previous axes into this frame, so that
    ///   each new axis is matched to the same axis with the same sign.
    pub fn estimate(
        &mut self,
        planes: &[Plane],
        line_dirs: &[Vector3<f32>],
        line_weights: &[f32],
        predicted_rotation: Option<&Rotation3<f64>>,
    ) -> Option<ManhattanAxes> {
        // A prediction that is not a finite rotation is projected onto SO(3), or
        // ignored when that fails, so that it can never poison the history.
        let step = predicted_rotation.and_then(|r| closest_rotation(r.matrix()));
        let predicted = self.previous.map(|prev| step.map_or(prev, |r| r * prev));
        self.collect_directions(planes, line_dirs, line_weights);
        let axes = self.solve(predicted.as_ref());
        self.previous = match &axes {
            Some(axes) => Some(axes.rotation),
            None => predicted,
        };
        axes
    }

    /// Fills `directions` with unit vectors whose weights sum to 1: planes get
    /// `ma_plane_share` of the vote when lines are present too.
    fn collect_directions(&mut self, planes: &[Plane], dirs: &[Vector3<f32>], weights: &[f32]) {
        self.directions.clear();
        let unit = |v: Vector3<f64>, w: f64, plane: bool| {
            let norm = v.norm();
            (norm > 0.0 && norm.is_finite() && w > 0.0 && w.is_finite()).then(|| Direction {
                dir: v / norm,
                weight: w,
                plane,
            })
        };
        self.directions.extend(planes.iter().filter_map(|p| {
            let n = Vector3::new(p.normal[0], p.normal[1], p.normal[2]).cast::<f64>();
            unit(n, f64::from(p.pixels), true)
        }));
        let plane_count = self.directions.len();
        self.directions.extend(
            dirs.iter()
                .zip(weights)
                .filter_map(|(d, &w)| unit(d.cast::<f64>(), f64::from(w), false)),
        );
        let (planes, lines) = self.directions.split_at_mut(plane_count);
        let share = match (planes.is_empty(), lines.is_empty()) {
            (false, false) => self.plane_share,
            (false, true) => 1.0,
            _ => 0.0,
        };
        normalise_weights(planes, share);
        normalise_weights(lines, 1.0 - share);
        self.directions.retain(|d| d.weight > 0.0);
    }

    fn solve(&mut self, predicted: Option<&Rotation3<f64>>) -> Option<ManhattanAxes> {
        if self.directions.is_empty() {
            return None;
        }
        // The best pair and the prediction are both refined; the prediction wins ties,
        // so that a frame does not jump between equally good structures.
        // The prediction is also tried turned onto the heaviest direction, which is what
        // completes a frame that sees one direction only, or rotated further than the
        // inlier angle since the last one.
        let mut rotation = self.best_pair().map(|r| self.refine(r));
        let heaviest = self.directions[*self.order.first()?].dir;
        if let Some(p) = predicted {
            for candidate in [*p, align_closest_axis(p, &heaviest)] {
                let refined = self.refine(candidate);
                if rotation.is_none_or(|r| self.score(&refined) >= self.score(&r)) {
                    rotation = Some(refined);
                }
            }
        }
        let rotation = match rotation {
            Some(r) => r,
            // No orthogonal pair and no history: the heaviest direction alone.
            None => self.refine(from_two_axes(
                heaviest,
                heaviest.cross(&least_aligned_basis(heaviest)),
            )?),
        };
        let (support, has_plane) = self.support(&rotation);
        let total: f64 = support.iter().sum();
        let observed = [0, 1, 2].map(|k| has_plane[k] || support[k] >= self.min_axis_support);
        let observed_count = observed.iter().filter(|&&o| o).count();
        if total < self.min_support || observed_count == 0 {
            return None;
        }
        let soft = self.score(&rotation);
        // With one axis the rotation about it is unobserved: a third of the information.
        let completeness = if observed_count >= 2 { 1.0 } else { 1.0 / 3.0 };
        let axes = ManhattanAxes {
            rotation,
            observed,
            support: support.map(|s| s as f32),
            confidence: (soft * completeness).clamp(0.0, 1.0) as f32,
        };
        Some(match predicted {
            Some(p) => match_to(&axes, p),
            None => axes.canonical(),
        })
    }

    /// The best-scoring hypothesis made of a near-orthogonal pair of heavy directions
    /// (third axis by cross product), if any; leaves the heaviest directions in `order`.
    fn best_pair(&mut self) -> Option<Rotation3<f64>> {
        self.order.clear();
        self.order.extend(0..self.directions.len());
        let dirs = &self.directions;
        self.order
            .sort_by(|&a, &b| dirs[b].weight.total_cmp(&dirs[a].weight));
        self.order.truncate(HYPOTHESIS_DIRECTIONS);
        let mut best: Option<(f64, Rotation3<f64>)> = None;
        for (k, &i) in self.order.iter().enumerate() {
            for &j in &self.order[k + 1..] {
                let (a, b) = (self.directions[i].dir, self.directions[j].dir);
                if a.dot(&b).abs() > self.sin_orthogonal {
                    continue;
                }
                let Some(r) = from_two_axes(a, b) else {
                    continue;
                };
                let score = self.score(&r);
                if best.is_none_or(|(s, _)| score > s) {
                    best = Some((score, r));
                }
            }
        }
        best.map(|(_, r)| r)
    }

    /// Weighted soft inlier count: each direction scores `1 - (1 - |cos|) / (1 - cos_in)`
    /// (about `1 - (angle / inlier_angle)^2`) on its closest axis, 0 beyond the threshold.
    fn score(&self, r: &Rotation3<f64>) -> f64 {
        let m = r.matrix();
        let span = 1.0 - self.cos_inlier;
        self.directions
            .iter()
            .map(|d| {
                let c = (m.transpose() * d.dir).abs().max();
                d.weight * (1.0 - (1.0 - c) / span).max(0.0)
            })
            .sum()
    }

    /// Weight of the directions within the inlier angle of each axis, and whether a
    /// plane normal is among them.
    fn support(&self, r: &Rotation3<f64>) -> ([f64; 3], [bool; 3]) {
        let mut support = [0.0; 3];
        let mut has_plane = [false; 3];
        for d in &self.directions {
            let c = (r.matrix().transpose() * d.dir).abs();
            let k = c.imax();
            if c[k] >= self.cos_inlier {
                support[k] += d.weight;
                has_plane[k] |= d.plane;
            }
        }
        (support, has_plane)
    }

    /// Least-squares axes: each axis column is the weighted sum of its sign-aligned
    /// inliers (plus a small pull towards the current axes, which alone decides the axes
    /// no direction sees), projected onto SO(3).
    fn refine(&self, mut r: Rotation3<f64>) -> Rotation3<f64> {
        for _ in 0..REFINE_ROUNDS {
            let mut m: Matrix3<f64> = r.matrix() * PRIOR_WEIGHT;
            for d in &self.directions {
                let c = r.matrix().transpose() * d.dir;
                let k = c.iamax();
                if c[k].abs() >= self.cos_inlier {
                    let mut col = m.column_mut(k);
                    col += d.dir * (d.weight * c[k].signum());
                }
            }
            match closest_rotation(&m) {
                Some(next) => r = next,
                None => break,
            }
        }
        r
    }
}

/// Scales the weights of `dirs` to sum to `share` (all zero when they sum to zero).
fn normalise_weights(dirs: &mut [Direction], share: f64) {
    let sum: f64 = dirs.iter().map(|d| d.weight).sum();
    let k = if sum > 0.0 { share / sum } else { 0.0 };
    dirs.iter_mut().for_each(|d| d.weight *= k);
}

/// The rotation with first axis `a` and second axis `b` made orthogonal to it; `None`
/// when they are parallel.
fn from_two_axes(a: Vector3<f64>, b: Vector3<f64>) -> Option<Rotation3<f64>> {
    let a = a.try_normalize(1e-12)?;
    let b = (b - a * a.dot(&b)).try_normalize(1e-9)?;
    Some(Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
        a,
        b,
        a.cross(&b),
    ])))
}

/// `r` turned by the smallest rotation that makes its axis closest to `dir` (either
/// sign) parallel to it.
fn align_closest_axis(r: &Rotation3<f64>, dir: &Vector3<f64>) -> Rotation3<f64> {
    let c = r.matrix().transpose() * dir;
    let k = c.iamax();
    let axis = r.matrix().column(k) * c[k].signum();
    Rotation3::rotation_between(&axis, dir).map_or(*r, |turn| turn * r)
}

/// The camera basis vector least aligned with `a` (never parallel to it).
fn least_aligned_basis(a: Vector3<f64>) -> Vector3<f64> {
    let mut e = Vector3::zeros();
    e[a.abs().imin()] = 1.0;
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(n: [f32; 3], pixels: u32) -> Plane {
        Plane {
            normal: n,
            offset: 1.0,
            pixels,
            centroid: [0.0, 0.0, 1.0],
        }
    }

    #[test]
    fn no_direction_or_random_directions_give_no_ma() {
        let mut est = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
        assert!(est.estimate(&[], &[], &[], None).is_none());
        // 40 well-spread directions (a golden-angle spiral): no orthogonal triplet holds
        // 30 % of them within 5 deg.
        let dirs: Vec<Vector3<f32>> = (0..40)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / 40.0;
                let phi = i as f32 * 2.399_963;
                let r = (1.0 - z * z).sqrt();
                Vector3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        assert!(est.estimate(&[], &dirs, &[1.0; 40], None).is_none());
    }

    #[test]
    fn a_non_finite_prediction_is_ignored() {
        let mut est = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
        let walls = [plane([0.0, 0.0, -1.0], 9000), plane([1.0, 0.0, 0.0], 5000)];
        let first = est.estimate(&walls, &[], &[], None).unwrap();
        let nan = Rotation3::from_matrix_unchecked(Matrix3::repeat(f64::NAN));
        let second = est.estimate(&walls, &[], &[], Some(&nan)).unwrap();
        let diff = (second.rotation.matrix() - first.rotation.matrix()).amax();
        assert!(diff < 1e-9, "{first:?} {second:?}");
        assert!(
            est.previous()
                .unwrap()
                .matrix()
                .iter()
                .all(|x| x.is_finite())
        );
    }

    #[test]
    fn one_plane_gives_one_observed_axis_with_low_confidence() {
        let mut est = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
        let axes = est
            .estimate(&[plane([0.0, -1.0, 0.0], 10_000)], &[], &[], None)
            .unwrap();
        assert_eq!(axes.observed.iter().filter(|&&o| o).count(), 1);
        assert!(axes.confidence <= 0.34, "{}", axes.confidence);
        let k = axes.observed.iter().position(|&o| o).unwrap();
        assert!((axes.axis(k).y.abs() - 1.0).abs() < 1e-9);
    }
}
