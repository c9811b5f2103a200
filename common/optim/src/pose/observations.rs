//! The public inputs of a pose optimisation: one observation type per term kind, all
//! plain data borrowed for the call.

use crate::residuals::{IntensityGrid, PhotometricReading, PlaneToPlane, PosePrior};
#[cfg(doc)]
use crate::residuals::{LineReprojection, Photometric, PointToPlane, StereoPointReprojection};
use nalgebra::{Isometry3, RowVector2, SMatrix, Vector2, Vector3, Vector4};
use std::cell::RefCell;

#[cfg(doc)]
use super::PoseResult;

/// A map point matched to a keypoint of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointObservation {
    /// The map point, world frame, metres (held fixed).
    pub point_in_world: Vector3<f64>,
    /// The keypoint, undistorted pixels (u, v).
    pub uv: Vector2<f64>,
    /// Information of the keypoint, 1/px^2 (see [`crate::robust::inv_sigma2_for_level`]).
    pub inv_sigma2: f64,
    /// Measured depth of the keypoint, metres; `0.0` (or any value <= 0) when there is
    /// none or it is not trusted (ORB-SLAM2 keeps depth for points closer than 40
    /// baselines): the error is then the 2D reprojection only, else the RGB-D error
    /// of [`StereoPointReprojection`].
    pub depth: f64,
}

/// A map line matched to a 2D line of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineObservation {
    /// The map line's endpoints `[S, E]`, world frame, metres (held fixed).
    pub endpoints_in_world: [Vector3<f64>; 2],
    /// The observed line `(a, b, c)`, `a^2 + b^2 = 1`, pixels (see [`LineReprojection`]).
    pub coeffs: Vector3<f64>,
    /// Information of the endpoint distances, 1/px^2.
    pub inv_sigma2: f64,
}

/// A depth point of the frame associated with a reference surface element (projective
/// point-to-plane alignment, see [`PointToPlane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthObservation {
    /// The frame's depth point, camera frame, metres.
    pub point_in_camera: Vector3<f64>,
    /// The reference surface point, world frame, metres (held fixed).
    pub surface_in_world: Vector3<f64>,
    /// The reference surface's unit normal, world frame.
    pub normal_in_world: Vector3<f64>,
    /// Information of the point-to-plane distance, 1/m^2 (the depth noise of both ends).
    pub inv_sigma2: f64,
    /// Variance of the reference normal's tilt along each direction of its plane, rad^2
    /// (0 for an exact normal). A tilt `d` turns the point's offset `t` along the plane
    /// into a distance `d . t`, which costs `inv_sigma2 v |t|^2` on average: the pair
    /// would pull the pose to where it was paired, whatever the surface says. That
    /// average is taken out of the cost.
    pub normal_tilt_variance: f64,
}

/// A reference surface point with its intensity, for the frame's intensity grid (see
/// [`Photometric`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotometricObservation {
    /// The reference point, world frame, metres (held fixed).
    pub point_in_world: Vector3<f64>,
    /// Its intensity in the reference, gray levels.
    pub intensity: f64,
    /// The reference's intensity gradient there, gray levels per pixel: beside the
    /// frame's, it measures how noisy the gradients are (see [`PoseResult::information`]).
    pub reference_gradient: RowVector2<f64>,
    /// Information of the intensity difference, 1/gray level^2.
    pub inv_sigma2: f64,
}

/// The photometric term of a pose optimisation: reference points and the frame's
/// intensity grid they are read in. The exposure may differ between the two: the frame's
/// intensity is compared with the reference's times the gain that fits the inliers best
/// at the pose evaluated, `g = sum I_c I_r / sum I_r^2` (the gain eliminated in closed
/// form: at its optimum the gradient of the reduced cost is `sum J^T e` with the gain
/// held, so the pose's steps need no gain derivative). A gain estimated once before the
/// optimisation would absorb part of the motion: a shading ramp looks like a change of
/// exposure.
#[derive(Clone, Copy, Debug)]
pub struct PhotometricTerm<'a> {
    /// The frame's intensities.
    pub image: IntensityGrid<'a>,
    /// The reference points.
    pub observations: &'a [PhotometricObservation],
    /// Where the optimiser keeps the points' readings of the pose being evaluated:
    /// owned by the caller, so that its buffer is reused from frame to frame.
    pub scratch: &'a PhotometricScratch,
}

/// The readings of a [`PhotometricTerm`]'s points at one pose (reused buffer).
#[derive(Debug, Default)]
pub struct PhotometricScratch {
    pub(crate) readings: RefCell<Vec<Option<PhotometricReading>>>,
}

/// A plane of the frame associated with a map plane (see [`PlaneToPlane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneObservation {
    /// The map plane's unit normal, world frame (held fixed).
    pub normal_in_world: Vector3<f64>,
    /// The map plane's offset, metres (`n_w . p + d_w = 0`, held fixed).
    pub offset_in_world: f64,
    /// The frame's measurement of it, camera frame.
    pub measured: PlaneToPlane,
    /// Information of the normal's difference, 1/rad^2.
    pub inv_sigma2_normal: f64,
    /// Information of the offset's difference, 1/m^2.
    pub inv_sigma2_offset: f64,
}

impl PlaneObservation {
    /// The pose Jacobian of the whitened error.
    pub fn whitened_d_pose(&self, d_pose: &SMatrix<f64, 4, 6>) -> SMatrix<f64, 4, 6> {
        let mut j = *d_pose;
        j.fixed_rows_mut::<3>(0)
            .scale_mut(self.inv_sigma2_normal.sqrt());
        j.row_mut(3).scale_mut(self.inv_sigma2_offset.sqrt());
        j
    }

    /// The whitened error (each row times the square root of its information).
    pub fn whitened_error(&self, pose: &Isometry3<f64>) -> Vector4<f64> {
        let e = self
            .measured
            .error(pose, &self.normal_in_world, self.offset_in_world);
        self.whiten(e)
    }

    /// Each row of an error (or a Jacobian column) times the square root of its
    /// information.
    pub fn whiten(&self, mut e: Vector4<f64>) -> Vector4<f64> {
        let (wn, wd) = (self.inv_sigma2_normal.sqrt(), self.inv_sigma2_offset.sqrt());
        e.fixed_rows_mut::<3>(0).scale_mut(wn);
        e[3] *= wd;
        e
    }
}

/// The terms of a pose optimisation besides points and lines: depth point-to-plane
/// pairs, plane-to-plane observations, the photometric term and a prior on the pose.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceObservations<'a> {
    /// Depth points paired with reference surface elements.
    pub depth: &'a [DepthObservation],
    /// Frame planes associated with map planes.
    pub planes: &'a [PlaneObservation],
    /// Reference intensities read in the frame's image, when any.
    pub photometric: Option<PhotometricTerm<'a>>,
    /// The motion model's prediction, when the pose is drawn towards it: it holds the
    /// directions the data leave weak. Not robustified, not counted as an inlier, not
    /// in [`PoseResult::information`] (which says what the data constrain).
    pub prior: Option<PosePrior>,
}
