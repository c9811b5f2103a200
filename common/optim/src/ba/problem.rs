//! The local bundle-adjustment problem as plain data: variables in vectors, every term
//! referring to them by index into those vectors.

use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Vector2, Vector3};
use thiserror::Error;

/// A keyframe pose of the problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaPose {
    /// `camera_from_world` (T_cw); updated in place when not fixed.
    pub camera_from_world: Isometry3<f64>,
    /// Held fixed (gauge, or a keyframe outside the covisible set, paper `K_f`).
    pub fixed: bool,
}

/// An observation of a map point by a keyframe (paper eq. 10, `E_R`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaPointObservation {
    /// Index into [`BaProblem::poses`].
    pub pose: usize,
    /// Index into [`BaProblem::points`].
    pub point: usize,
    /// Keypoint, undistorted pixels (u, v).
    pub uv: Vector2<f64>,
    /// Information, 1/px^2 (see [`crate::robust::inv_sigma2_for_level`]).
    pub inv_sigma2: f64,
    /// Measured depth, metres; `<= 0` for none: 2D error only, else the RGB-D error
    /// ([`crate::residuals::StereoPointReprojection`]), which fixes depth and scale.
    pub depth: f64,
}

/// An observation of a map line by a keyframe: endpoint-to-line distances (eq. 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaLineObservation {
    /// Index into [`BaProblem::poses`].
    pub pose: usize,
    /// Index into [`BaProblem::lines`].
    pub line: usize,
    /// Observed line `(a, b, c)`, `a^2 + b^2 = 1`, pixels.
    pub coeffs: Vector3<f64>,
    /// Information, 1/px^2.
    pub inv_sigma2: f64,
}

/// A map line associated with a Manhattan axis (eq. 14).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaManhattan {
    /// Index into [`BaProblem::lines`].
    pub line: usize,
    /// Unit axis direction, world frame (held fixed).
    pub axis: Vector3<f64>,
}

/// Where depth measured a map line: its endpoints are held near there with the depth
/// noise as sigma. Its 2D observations leave a line free to slide along the viewing
/// rays when the keyframes that see it are close together, and only depth, not the
/// image, says where it is along them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaLinePrior {
    /// Index into [`BaProblem::lines`].
    pub line: usize,
    /// The measured endpoints `[S, E]`, world frame, metres.
    pub endpoints: [Vector3<f64>; 2],
    /// Information of each endpoint's position, 1/m^2 (isotropic).
    pub information: [f64; 2],
}

/// A keyframe's observation of a map plane: the plane-to-plane error of its pose and
/// the plane ([`crate::residuals::PlaneToPlane`]); it ties the keyframes that see the
/// same wall or floor together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaPlaneObservation {
    /// Index into [`BaProblem::poses`].
    pub pose: usize,
    /// Index into [`BaProblem::planes`].
    pub plane: usize,
    /// The keyframe's measurement of the plane, camera frame.
    pub measured: crate::residuals::PlaneToPlane,
    /// Information of the normal's difference, 1/rad^2.
    pub inv_sigma2_normal: f64,
    /// Information of the offset's difference, 1/m^2.
    pub inv_sigma2_offset: f64,
}

/// A map plane whose normal is tied to a Manhattan axis
/// ([`crate::residuals::PlaneAxis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaPlaneAxis {
    /// Index into [`BaProblem::planes`].
    pub plane: usize,
    /// Unit axis direction, world frame (held fixed).
    pub axis: Vector3<f64>,
}

/// The variables and terms of one local BA. Points and lines are updated in place.
#[derive(Clone, Debug)]
pub struct BaProblem {
    /// Intrinsics of the (undistorted) images of every keyframe.
    pub camera: PinholeCamera,
    /// Keyframe poses; at least one must be fixed. With 2D errors only (no depth) one
    /// fixed pose leaves the scale free: fix two or more, or give depths.
    pub poses: Vec<BaPose>,
    /// Map points, world frame, metres.
    pub points: Vec<Vector3<f64>>,
    /// Map lines as their two endpoints `[S, E]`, world frame, metres.
    pub lines: Vec<[Vector3<f64>; 2]>,
    /// Map planes `(unit normal, offset)`, `n . p + d = 0`, world frame; updated on S2 x
    /// R ([`crate::residuals::plane_plus`]).
    pub planes: Vec<(Vector3<f64>, f64)>,
    /// Point observations.
    pub point_observations: Vec<BaPointObservation>,
    /// Line observations.
    pub line_observations: Vec<BaLineObservation>,
    /// Pairs of line indices that should be parallel (eq. 11, 13).
    pub parallel: Vec<(usize, usize)>,
    /// Pairs of line indices that should be perpendicular (eq. 11, 12).
    pub perpendicular: Vec<(usize, usize)>,
    /// Line <-> Manhattan axis associations (eq. 14).
    pub manhattan: Vec<BaManhattan>,
    /// Depth priors of lines (at most one per line).
    pub line_priors: Vec<BaLinePrior>,
    /// Keyframe observations of map planes.
    pub plane_observations: Vec<BaPlaneObservation>,
    /// Pairs of plane indices whose normals should be parallel (either sign).
    pub plane_parallel: Vec<(usize, usize)>,
    /// Pairs of plane indices whose normals should be perpendicular.
    pub plane_perpendicular: Vec<(usize, usize)>,
    /// Plane <-> Manhattan axis associations.
    pub plane_axes: Vec<BaPlaneAxis>,
}

impl BaProblem {
    /// An empty problem for `camera`.
    pub fn new(camera: PinholeCamera) -> Self {
        Self {
            camera,
            poses: Vec::new(),
            points: Vec::new(),
            lines: Vec::new(),
            planes: Vec::new(),
            point_observations: Vec::new(),
            line_observations: Vec::new(),
            parallel: Vec::new(),
            perpendicular: Vec::new(),
            manhattan: Vec::new(),
            line_priors: Vec::new(),
            plane_observations: Vec::new(),
            plane_parallel: Vec::new(),
            plane_perpendicular: Vec::new(),
            plane_axes: Vec::new(),
        }
    }

    /// Checks indices, finiteness and the gauge.
    ///
    /// # Errors
    /// [`BaError::IndexOutOfRange`], [`BaError::NonFinite`] or [`BaError::NoFixedPose`].
    pub fn validate(&self) -> Result<(), BaError> {
        let check = |list, entry, field, index: usize, len: usize| {
            if index < len {
                Ok(())
            } else {
                Err(BaError::IndexOutOfRange {
                    list,
                    entry,
                    field,
                    index,
                    len,
                })
            }
        };
        let finite = |list, entry, ok: bool| {
            if ok {
                Ok(())
            } else {
                Err(BaError::NonFinite { list, entry })
            }
        };
        let (np, nx, nl) = (self.poses.len(), self.points.len(), self.lines.len());
        for (i, p) in self.poses.iter().enumerate() {
            let t = &p.camera_from_world;
            let ok = t.translation.vector.iter().all(|v| v.is_finite())
                && t.rotation.coords.iter().all(|v| v.is_finite());
            finite("poses", i, ok)?;
        }
        for (i, x) in self.points.iter().enumerate() {
            finite("points", i, x.iter().all(|v| v.is_finite()))?;
        }
        for (i, l) in self.lines.iter().enumerate() {
            finite(
                "lines",
                i,
                l.iter().flat_map(|e| e.iter()).all(|v| v.is_finite()),
            )?;
        }
        for (i, o) in self.point_observations.iter().enumerate() {
            check("point_observations", i, "pose", o.pose, np)?;
            check("point_observations", i, "point", o.point, nx)?;
            let ok = o.uv.iter().all(|v| v.is_finite())
                && o.inv_sigma2.is_finite()
                && o.depth.is_finite();
            finite("point_observations", i, ok)?;
        }
        for (i, o) in self.line_observations.iter().enumerate() {
            check("line_observations", i, "pose", o.pose, np)?;
            check("line_observations", i, "line", o.line, nl)?;
            let ok = o.coeffs.iter().all(|v| v.is_finite()) && o.inv_sigma2.is_finite();
            finite("line_observations", i, ok)?;
        }
        for (list, pairs) in [
            ("parallel", &self.parallel),
            ("perpendicular", &self.perpendicular),
        ] {
            for (i, &(a, b)) in pairs.iter().enumerate() {
                check(list, i, "first", a, nl)?;
                check(list, i, "second", b, nl)?;
            }
        }
        for (i, m) in self.manhattan.iter().enumerate() {
            check("manhattan", i, "line", m.line, nl)?;
            finite("manhattan", i, m.axis.iter().all(|v| v.is_finite()))?;
        }
        for (i, prior) in self.line_priors.iter().enumerate() {
            check("line_priors", i, "line", prior.line, nl)?;
            let ok = prior
                .endpoints
                .iter()
                .flat_map(|e| e.iter())
                .all(|v| v.is_finite())
                && prior.information.iter().all(|w| w.is_finite() && *w >= 0.0);
            finite("line_priors", i, ok)?;
        }
        for (i, (n, d)) in self.planes.iter().enumerate() {
            let ok = n.iter().all(|v| v.is_finite()) && (n.norm() - 1.0).abs() < 1e-6;
            finite("planes", i, ok && d.is_finite())?;
        }
        for (i, o) in self.plane_observations.iter().enumerate() {
            check("plane_observations", i, "pose", o.pose, np)?;
            check("plane_observations", i, "plane", o.plane, self.planes.len())?;
            let ok = o.measured.normal_in_camera.iter().all(|v| v.is_finite())
                && o.measured.offset.is_finite()
                && o.inv_sigma2_normal.is_finite()
                && o.inv_sigma2_offset.is_finite();
            finite("plane_observations", i, ok)?;
        }
        let nq = self.planes.len();
        for (list, pairs) in [
            ("plane_parallel", &self.plane_parallel),
            ("plane_perpendicular", &self.plane_perpendicular),
        ] {
            for (i, &(a, b)) in pairs.iter().enumerate() {
                check(list, i, "first", a, nq)?;
                check(list, i, "second", b, nq)?;
            }
        }
        for (i, m) in self.plane_axes.iter().enumerate() {
            check("plane_axes", i, "plane", m.plane, nq)?;
            finite("plane_axes", i, m.axis.iter().all(|v| v.is_finite()))?;
        }
        if np > 0 && self.poses.iter().all(|p| !p.fixed) {
            return Err(BaError::NoFixedPose { poses: np });
        }
        Ok(())
    }
}

/// Why a local BA could not run.
#[derive(Debug, Error, PartialEq)]
pub enum BaError {
    /// A term refers to a variable that does not exist.
    #[error("{list}[{entry}].{field} = {index} is out of range (len {len})")]
    IndexOutOfRange {
        /// The list holding the term.
        list: &'static str,
        /// Index of the term in its list.
        entry: usize,
        /// The field that holds the bad index.
        field: &'static str,
        /// The bad index.
        index: usize,
        /// Length of the list it indexes.
        len: usize,
    },
    /// A value is NaN or infinite.
    #[error("{list}[{entry}] holds a non-finite value")]
    NonFinite {
        /// The list holding the value.
        list: &'static str,
        /// Index in that list.
        entry: usize,
    },
    /// No pose is fixed: the problem has a free gauge.
    #[error("none of the {poses} poses is fixed; fix at least one (gauge)")]
    NoFixedPose {
        /// Number of poses.
        poses: usize,
    },
    /// The sparse solver could not be set up (allocation or index overflow).
    #[error("sparse solver setup failed for a {dimension}x{dimension} system: {reason}")]
    Solver {
        /// Size of the reduced system.
        dimension: usize,
        /// faer's message.
        reason: String,
    },
}
