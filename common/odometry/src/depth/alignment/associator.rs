//! The depth pairs of a frame with its reference: association, the per-pair noise and
//! the normals' noise estimated from the pairs (see the module above).

use super::DepthAlignmentConfig;
use crate::depth::grid::PosedGrid;
use gfs_core::camera::PinholeCamera;
use gfs_optim::DepthObservation;
use gfs_planes::Plane;
use nalgebra::{Isometry3, Matrix6, Point3, Vector3};

/// Largest angle between a node's normal and a plane's for the node to lie on that
/// plane, degrees: the planes stage's own region gate.
const ON_PLANE_ANGLE_DEG: f64 = 15.0;
/// Largest distance of a node from a plane for it to lie on that plane, in the
/// sensor's depth sigmas at the node.
const ON_PLANE_SIGMAS: f64 = 3.0;

/// Pairs a frame's depth nodes with the reference frame's surface elements.
#[derive(Debug, Default)]
pub struct DepthAssociator {
    observations: Vec<DepthObservation>,
    /// Per pair, the sensor's and the association's variance, the squared tangential
    /// offset of the two nodes, and the reference normal's noise variance as a share of
    /// one node's (a blend of nodes averages their noise; reused).
    variances: Vec<(f64, f64, f64)>,
    /// Per pair, the squared angle between the two normals, rad^2, scaled to two
    /// single nodes' normals (reused).
    angles2: Vec<f64>,
    /// Variance of one node normal's tilt along a tangent direction, rad^2, from the
    /// angles between the last pass's paired normals.
    normal_variance: f64,
    /// The frame's sampled nodes the last pass tried to pair.
    source_nodes: usize,
    /// The frame's planes (unit normal towards the camera, offset), camera frame: a
    /// node on one is paired along the plane's normal (reused).
    planes: Vec<(Vector3<f64>, f64)>,
}

impl DepthAssociator {
    /// Sets the planes of the frame the next passes pair (empty: none). A node on one of
    /// them is paired along the plane's normal instead of its own: a depth sensor's
    /// error is smooth across the image and moves with the camera (a triangulating
    /// sensor's disparity field), so a wall's nodes curve and tilt the same way in
    /// consecutive frames; along their own normals, that shared curvature would hold
    /// the slide of a bare wall, which its plane leaves free, and pull the pose to where
    /// the curvature sits in the image.
    pub fn set_frame_planes(&mut self, planes: &[Plane]) {
        self.planes.clear();
        self.planes.extend(planes.iter().map(|p| {
            let [x, y, z] = p.normal.map(f64::from);
            (Vector3::new(x, y, z), f64::from(p.offset))
        }));
    }

    /// The plane `q` (normal `normal`, camera frame) lies on, if any: within
    /// [`ON_PLANE_ANGLE_DEG`] of its normal and [`ON_PLANE_SIGMAS`] depth sigmas of it.
    fn plane_of(
        &self,
        config: &DepthAlignmentConfig,
        q: &Vector3<f64>,
        normal: &Vector3<f64>,
    ) -> Option<Vector3<f64>> {
        let min_cos = ON_PLANE_ANGLE_DEG.to_radians().cos();
        let gate = ON_PLANE_SIGMAS * config.noise.sigma(q.z);
        self.planes
            .iter()
            .find(|(n, d)| n.dot(normal) >= min_cos && (n.dot(q) + d).abs() <= gate)
            .map(|(n, _)| *n)
    }

    /// The pairs of `current` (at `current_from_world`) with `reference` (at
    /// `reference_from_world`) within `max_distance_m`, as world-frame observations;
    /// the sensor's share of their variance is scaled by `sensor_variance_scale`.
    pub fn associate(
        &mut self,
        config: &DepthAlignmentConfig,
        camera: &PinholeCamera,
        current: PosedGrid,
        reference: PosedGrid,
        max_distance_m: f64,
        sensor_variance_scale: f64,
    ) -> &[DepthObservation] {
        let PosedGrid {
            grid: current,
            camera_from_world: current_from_world,
        } = current;
        let PosedGrid {
            grid: reference,
            camera_from_world: reference_from_world,
        } = reference;
        self.observations.clear();
        self.variances.clear();
        self.angles2.clear();
        self.source_nodes = 0;
        let world_from_reference = reference_from_world.inverse();
        let world_from_current = current_from_world.inverse();
        let reference_from_current = reference_from_world * current_from_world.inverse();
        let min_cos = config.max_normal_angle_deg.to_radians().cos();
        let step = config.source_step.max(1);
        let width = current.width as usize;
        for j in (step / 2..current.height as usize).step_by(step) {
            for i in (step / 2..width).step_by(step) {
                let Some((q, q_normal)) = current.node(j * width + i) else {
                    continue;
                };
                self.source_nodes += 1;
                let in_reference = reference_from_current * Point3::from(q);
                let Some(uv) = camera.project(&in_reference) else {
                    continue;
                };
                let Some((s, n, share)) =
                    reference.surface_at_pixel(uv.x, uv.y, min_cos, max_distance_m)
                else {
                    continue;
                };
                // Along the normal within the gate; across it, within the gate plus a
                // node's footprint (the node is its block's mean point, not the pixel's).
                let offset = in_reference.coords - s;
                let footprint = f64::from(reference.stride_px) * s.z / camera.fx;
                let cos = (reference_from_current.rotation * q_normal).dot(&n);
                if n.dot(&offset).abs() > max_distance_m
                    || offset.norm() > max_distance_m + footprint
                    || cos < min_cos
                {
                    continue;
                }
                // The frame's node and the reference's surface tilt with variances v and
                // share * v: their angle scaled as between two nodes.
                self.angles2
                    .push(cos.clamp(-1.0, 1.0).acos().powi(2) * 2.0 / (1.0 + share));
                // The sensor noise of both ends, and the pass's association uncertainty:
                // a coarse pass pairs points up to its gate apart, and a tight chi-square
                // test would reject the only pairs of a weakly seen direction.
                let sigma2 = sensor_variance_scale
                    * (config.noise.sigma(q.z).powi(2) + config.noise.sigma(s.z).powi(2))
                    + (max_distance_m / 3.0).powi(2);
                let tangential = offset - n * n.dot(&offset);
                // On a plane, the plane's normal: fitted over the plane's many nodes,
                // its tilt noise is nobody's.
                let (normal_in_world, share) = match self.plane_of(config, &q, &q_normal) {
                    Some(plane_normal) => (world_from_current.rotation * plane_normal, 0.0),
                    None => (world_from_reference.rotation * n, share),
                };
                self.variances
                    .push((sigma2, tangential.norm_squared(), share));
                self.observations.push(DepthObservation {
                    point_in_camera: q,
                    surface_in_world: (world_from_reference * Point3::from(s)).coords,
                    normal_in_world,
                    inv_sigma2: 0.0,
                    normal_tilt_variance: 0.0,
                });
            }
        }
        // Beyond the tracking's coarsest gate the pass is the coarse registration's,
        // whose paired normals differ by the pose's error, not by their noise.
        self.normal_variance = if max_distance_m > config.occlusion_m() {
            0.0
        } else {
            tangent_variance_from_angles(&mut self.angles2)
        };
        // The reference normal's tilt across the nodes' tangential offset (they are
        // not the same surface point) is in the distance too. The Kinect model was
        // fitted to depth deviations from planes, its normals' tilt included; only a
        // node's averaged sigma leaves it out.
        let tilt_variance = if sensor_variance_scale < 1.0 {
            self.normal_variance
        } else {
            0.0
        };
        for (o, (sigma2, tangential2, share)) in self.observations.iter_mut().zip(&self.variances) {
            o.inv_sigma2 = 1.0 / (sigma2 + tangential2 * tilt_variance * share);
            o.normal_tilt_variance = self.normal_variance * share;
        }
        &self.observations
    }

    /// The normals' tilt variance per tangent direction the last pass measured, rad^2
    /// ([`tangent_variance_from_angles`]).
    pub fn normal_variance(&self) -> f64 {
        self.normal_variance
    }

    /// The share of the frame's sampled nodes the last pass paired (0 without nodes).
    pub fn overlap(&self) -> f64 {
        if self.source_nodes == 0 {
            return 0.0;
        }
        self.observations.len() as f64 / self.source_nodes as f64
    }

    /// The information the last pass's pairs seem to give the pose (at
    /// `camera_from_world`) only because their normals are noisy: a node's normal tilted
    /// by `d` along a direction `e` of its surface lends it `w (d . e)^2` of
    /// information, where the surface gives none (a wall and the floor along their
    /// edge). Translation block only, `sum w sigma_n^2 (I - n n^T)`, over the pairs the
    /// optimisation kept (`inliers`, one flag per pair): a rejected pair lent the
    /// information nothing, so it has no noise to take out of it.
    pub fn normal_noise_information(
        &self,
        camera_from_world: &Isometry3<f64>,
        inliers: &[bool],
    ) -> Matrix6<f64> {
        let mut h = Matrix6::zeros();
        let pairs = self.observations.iter().zip(&self.variances).zip(inliers);
        for ((o, (_, _, share)), _) in pairs.filter(|(_, inlier)| **inlier) {
            let n = camera_from_world.rotation * o.normal_in_world;
            let tangent = nalgebra::Matrix3::identity() - n * n.transpose();
            let block = tangent * (o.inv_sigma2 * self.normal_variance * share);
            let mut translation = h.fixed_view_mut::<3, 3>(0, 0);
            translation += block;
        }
        h
    }
}

/// One normal's tilt variance along a tangent direction, rad^2, from the squared angles
/// between paired normals (reordered). Two independent normals, each tilted with two
/// tangent components of variance `v`, differ by an angle whose square is `2 v` times a
/// chi-square of two degrees of freedom, whose median is `2 ln 2`. The median, not the
/// mean: the pairs across a crease (a node's block mixing two surfaces) have normals
/// tens of degrees apart, and their mean would make the noise of a corner's normals
/// appear large enough to discount directions its planes do hold.
pub(super) fn tangent_variance_from_angles(angles2: &mut [f64]) -> f64 {
    if angles2.is_empty() {
        return 0.0;
    }
    let middle = angles2.len() / 2;
    let (_, median, _) = angles2.select_nth_unstable_by(middle, f64::total_cmp);
    *median / (4.0 * std::f64::consts::LN_2)
}
