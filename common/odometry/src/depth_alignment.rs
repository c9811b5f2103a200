//! Projective point-to-plane association of a frame's depth with the last frame's
//! (the depth geometry term of tracking, issue 17).
//!
//! The reference is the reference keyframe's depth at its pose in the map (`[tracking.
//! depth] keyframe_reference`, the default): frame-to-keyframe, the depth term does not
//! add up the frames' errors as frame-to-frame alignment does, and the local BA's
//! refinements of the keyframe reach the frame; the last frame (the nearest view) serves
//! when the keyframe's depth was not kept (a keyframe made of an earlier frame than the
//! last, as in the realtime pipeline).
//!
//! Each sampled node `q` of the frame's [`DepthGrid`] is moved into the reference with
//! the current estimate, projected, and paired with the reference's surface at that
//! pixel (its four nodes around it blended, [`DepthGrid::surface_at_pixel`]) when they
//! are close and their normals agree. The distance is weighed with the
//! Kinect depth noise of both ends, `sigma_z(z) = 0.0012 + 0.0019 (z - 0.4)^2` m
//! (Nguyen, Izadi and Lovell, 3DIMPVT 2012), averaged over a node's block where the
//! sensor's noise is independent from pixel to pixel
//! ([`DepthAlignmentConfig::independent_pixels_per_node`]).

use crate::depth_grid::DepthGrid;
use gfs_core::camera::PinholeCamera;
use gfs_optim::DepthObservation;
use gfs_optim::residuals::PointToPlane;
use nalgebra::{Isometry3, Matrix6, Point3};
use serde::Deserialize;

/// Parameters of the depth alignment (the odometry's TOML table `[tracking.depth]`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DepthAlignmentConfig {
    /// Every `source_step`-th node of the frame's grid (rows and columns) is aligned,
    /// and of the reference's sampled for the photometric term; default 2 (a 16 px
    /// grid: 1200 points of a VGA frame). A structured-light sensor's error is
    /// correlated from node to node: every node (1) took TUM fr1 and 7-Scenes with all
    /// terms over six start frames from 12.38 / 21.08 to 12.53 / 22.12 mm. `gfsvo synth`
    /// renders independent noise and writes 1 (`configs/synthetic.toml`).
    pub source_step: usize,
    /// Association gates of the successive passes, metres: a point farther than this
    /// from its reference node is not paired; coarse to fine, one re-association and
    /// pose optimisation per entry; default [0.08, 0.03, 0.015].
    pub max_distance_m: Vec<f64>,
    /// Largest angle between paired normals, degrees; default 30.
    pub max_normal_angle_deg: f64,
    /// Lever arm that makes rotations comparable with translations in the
    /// constraint analysis, metres; default 2.0 (a room's depth).
    pub lever_arm_m: f64,
    /// A pose direction whose standard deviation (metres at the lever arm) exceeds this
    /// is unconstrained: the frame is `degraded`; default 0.015 (1 cm flagged 20 frames
    /// of the synthetic low-texture fast seed 2 with 75 points, 14 lines and the depth,
    /// at 1.0-1.2 cm; 1.5 cm changes no other sequence but the lost rotation seed 1).
    pub max_sigma_m: f64,
    /// The depth term is added to a frame tracked on features when the features alone
    /// leave a direction with a standard deviation above this, metres; 0 = always;
    /// default 0.002 (always: TUM fr1 0.0151 m and 7-Scenes 0.0344 m instead of 0.0115
    /// and 0.0208 m, the real depth's bias weighs against well-placed features).
    pub weak_sigma_m: f64,
    /// Align with the reference keyframe's depth (at its pose in the map) instead of
    /// the last frame's; default true (synthetic low-texture slow seed 3: 3.1 mm
    /// instead of 7.7, rotation seed 3: 3.2 instead of 5.8; TUM fr1 0.0120 m instead of
    /// 0.0115, 7-Scenes 0.0208 m both).
    pub keyframe_reference: bool,
    /// Standard deviation of the photometric term's intensity difference (blurred 4 px
    /// cell means), gray levels; 0 = no photometric term; default 0.5 (a camera's 2
    /// gray levels of pixel noise leave about 0.15 on the difference of two such
    /// cells; with the motion prior, 0.4-0.6 took the synthetic low-texture rotation
    /// seed 1 to 7-18 mm, 1.0 to 16-31 mm). Samples at every node (`source_step` 1)
    /// are 8 px apart on cells blurred over 16 px and share their noise: `gfsvo synth`
    /// writes 0.7 (0.5 / 0.6 / 0.7 / 0.85: 18 / 19 / 20 / 17 of its 24 low-texture
    /// sequences within 4 mm).
    pub photometric_sigma: f64,
    /// Uncertainty of a depth node's position across the image, pixels: its intensity
    /// difference is uncertain by this times the intensity gradient there; default 1.0.
    pub photometric_position_sigma_px: f64,
    /// Add the photometric term to frames tracked on features too (whose features leave
    /// a direction above `weak_sigma_m`), not only to frames the features lost; default
    /// false (true: synthetic low-texture slow seeds 1-3 2.1 / 3.2 / 5.3 mm instead of
    /// 1.1 / 1.9 / 3.1 mm, the cells' interpolation and edges bias what the features
    /// measured well).
    pub photometric_on_features: bool,
    /// Frames tracked on geometry, or whose features leave a weak direction, are drawn
    /// towards the motion model's prediction (`motion_prior.rs`) as far as an unknown
    /// acceleration of this much moves a frame, `0.5 a dt^2` per axis, m/s^2; 0 = no
    /// prior; default 12 (6.7 mm at 30 Hz).
    pub motion_prior_accel_m_s2: f64,
    /// The rotational counterpart of `motion_prior_accel_m_s2` for frames tracked on
    /// depth and planes alone, deg/s^2; default 800 (0.44 degrees at 30 Hz).
    pub motion_prior_angular_accel_deg_s2: f64,
    /// The same for frames tracked on features, deg/s^2; default 3200 (1.8 degrees at
    /// 30 Hz: the features measure the rotation; 800 took TUM fr1_rpy from 11.3 to
    /// 12.5 mm).
    pub motion_prior_feature_angular_accel_deg_s2: f64,
    /// How fast the camera centre's velocity, which centres the prior, may change, m/s^2:
    /// each frame's step moves the velocity as far as its data placed the frame against
    /// this (`crate::motion_prior::FilteredVelocity`); default 4 (the 24 synthetic
    /// low-texture sequences with all terms 5.32 -> 4.20 mm against the step from the
    /// last two poses; 12, the prior's own: 5.60 mm).
    pub motion_prior_velocity_accel_m_s2: f64,
    /// The same for the camera's angular rate, which turns the prior, deg/s^2; 0 = the
    /// motion model's turn from the last two poses; default 200 (the 24 synthetic
    /// low-texture sequences with all terms 2.95 -> 2.88 mm, held-out seeds 9-12 8.98 ->
    /// 5.89 mm, 20 and 10 within 4 mm either way; rotation seed 1's bare-wall frames
    /// had carried 0.15 degrees of roll a frame; 100 / 400: 3.54 / 2.66 mm, 19 / 20).
    pub motion_prior_angular_rate_accel_deg_s2: f64,
    /// Pixels of a node's block whose depth noise is independent: on a frame tracked on
    /// features, a node's depth sigma is the pixel's over the square root of this, and
    /// the reference normal's tilt across the pair joins it; default 1 (a structured-
    /// light sensor's error is correlated across a block: 16 took 7-Scenes from 20.3 to
    /// 23.1 mm with all terms, fr1 stayed at 11.3). `gfsvo synth` writes 16 for its
    /// noise, independent from pixel to pixel: of a block's 64 pixels, holes and edges
    /// leave fewer (the 24 low-texture sequences with all terms: 4 / 8 / 16 / 32 / 64
    /// gave 5.72 / 5.45 / 5.78 / 5.58 / 5.62 mm, 13 / 13 / 15 / 13 / 12 within 4 mm,
    /// at every second node; at every node it writes 4: 4 / 8 / 16 gave 20 / 19 / 18).
    /// Frames tracked on their geometry alone keep the pixel's sigma: weighed up, the
    /// nodes' noisy normals outweigh the photometric term along the surfaces (16 there,
    /// with an earlier form of the tilt term: 11.7 mm mean).
    pub independent_pixels_per_node: f64,
    /// A frame tracked on its depth whose pose's worst direction has a standard
    /// deviation above this (metres at the lever arm), with fewer than
    /// `renewal_overlap` of its nodes paired with the reference's and its own surfaces
    /// fixing a pose within this, becomes a keyframe: the depth reference is renewed
    /// while the frame is still `tracked`, before the view leaves it (a `degraded`
    /// frame without points makes none, and in a room without keypoints no other rule
    /// asks for one in time); 0 = never; default 0.006 (the 24 synthetic low-texture
    /// sequences with all terms 5.78 -> 5.38 mm, 15 -> 17 within 4 mm: rotation seeds 4
    /// and 6 7.6 / 11.1 -> 3.5 / 3.7 mm with every frame `tracked`; a 4.5 mm trigger
    /// with the own surfaces still at 6 mm: 5.49 mm, 16).
    pub renewal_sigma_m: f64,
    /// Share of a frame's depth nodes paired with the reference below which its view
    /// has moved off the reference (`renewal_sigma_m`); default 0.85 (where most nodes
    /// pair, a weak direction is the surfaces', which a new reference does not fix:
    /// with 1.0 the 24 sequences' mean went to 5.56 mm, slow 5 22.3 -> 27.7 mm).
    pub renewal_overlap: f64,
}

impl Default for DepthAlignmentConfig {
    fn default() -> Self {
        Self {
            source_step: 2,
            max_distance_m: vec![0.08, 0.03, 0.015],
            max_normal_angle_deg: 30.0,
            lever_arm_m: 2.0,
            max_sigma_m: 0.015,
            weak_sigma_m: 0.002,
            keyframe_reference: true,
            photometric_sigma: 0.5,
            photometric_position_sigma_px: 1.0,
            photometric_on_features: false,
            motion_prior_accel_m_s2: 12.0,
            motion_prior_angular_accel_deg_s2: 800.0,
            motion_prior_feature_angular_accel_deg_s2: 3200.0,
            motion_prior_velocity_accel_m_s2: 4.0,
            motion_prior_angular_rate_accel_deg_s2: 200.0,
            independent_pixels_per_node: 1.0,
            renewal_sigma_m: 0.006,
            renewal_overlap: 0.85,
        }
    }
}

/// Standard deviation of a Kinect depth measurement at `z` metres.
pub fn kinect_depth_sigma(z: f64) -> f64 {
    0.0012 + 0.0019 * (z - 0.4).powi(2)
}

/// The information a frame's depth would give its own pose, were every sampled node
/// paired with itself: whether its surfaces can determine a pose at all (a frame of
/// one wall cannot).
pub fn self_information(config: &DepthAlignmentConfig, grid: &DepthGrid) -> Matrix6<f64> {
    let mut h = Matrix6::zeros();
    let step = config.source_step.max(1);
    let width = grid.width as usize;
    for j in (step / 2..grid.height as usize).step_by(step) {
        for i in (step / 2..width).step_by(step) {
            if let Some((q, n)) = grid.node(j * width + i) {
                let l =
                    PointToPlane { point_in_camera: q }.linearize(&Isometry3::identity(), &q, &n);
                h += l.d_pose.transpose() * l.d_pose / (2.0 * kinect_depth_sigma(q.z).powi(2));
            }
        }
    }
    h
}

/// Whether a frame tracked on its depth (`grid`, its pose's information
/// `pose_information` from pairs with the reference of which `overlap` is the share of
/// its nodes) has moved off its depth reference and should renew it
/// ([`DepthAlignmentConfig::renewal_sigma_m`]): its pose is weakly held, few of its
/// nodes pair, and its own surfaces would hold a pose (a frame of one wall, whose
/// slide a new reference would keep, does not qualify).
pub fn needs_new_reference(
    config: &DepthAlignmentConfig,
    pose_information: &Matrix6<f64>,
    overlap: f64,
    grid: &DepthGrid,
) -> bool {
    let sigma = |information: &Matrix6<f64>| {
        gfs_optim::analyse_constraint(information, config.lever_arm_m, config.max_sigma_m)
            .worst_sigma_m
    };
    config.renewal_sigma_m > 0.0
        && overlap < config.renewal_overlap
        && sigma(pose_information) > config.renewal_sigma_m
        && sigma(&self_information(config, grid)) < config.renewal_sigma_m
}

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
}

impl DepthAssociator {
    /// The pairs of `current` (at `current_from_world`) with `reference` (at
    /// `reference_from_world`) within `max_distance_m`, as world-frame observations;
    /// the sensor's share of their variance is scaled by `sensor_variance_scale`.
    #[allow(clippy::too_many_arguments)]
    pub fn associate(
        &mut self,
        config: &DepthAlignmentConfig,
        camera: &PinholeCamera,
        current: &DepthGrid,
        current_from_world: &Isometry3<f64>,
        reference: &DepthGrid,
        reference_from_world: &Isometry3<f64>,
        max_distance_m: f64,
        sensor_variance_scale: f64,
    ) -> &[DepthObservation] {
        self.observations.clear();
        self.variances.clear();
        self.angles2.clear();
        self.source_nodes = 0;
        let world_from_reference = reference_from_world.inverse();
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
                    * (kinect_depth_sigma(q.z).powi(2) + kinect_depth_sigma(s.z).powi(2))
                    + (max_distance_m / 3.0).powi(2);
                let tangential = offset - n * n.dot(&offset);
                self.variances
                    .push((sigma2, tangential.norm_squared(), share));
                self.observations.push(DepthObservation {
                    point_in_camera: q,
                    surface_in_world: (world_from_reference * Point3::from(s)).coords,
                    normal_in_world: world_from_reference.rotation * n,
                    inv_sigma2: 0.0,
                });
            }
        }
        self.normal_variance = tangent_variance_from_angles(&mut self.angles2);
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
        }
        &self.observations
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
    /// edge). Translation block only, `sum w sigma_n^2 (I - n n^T)`.
    pub fn normal_noise_information(&self, camera_from_world: &Isometry3<f64>) -> Matrix6<f64> {
        let mut h = Matrix6::zeros();
        for (o, (_, _, share)) in self.observations.iter().zip(&self.variances) {
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
fn tangent_variance_from_angles(angles2: &mut [f64]) -> f64 {
    if angles2.is_empty() {
        return 0.0;
    }
    let middle = angles2.len() / 2;
    let (_, median, _) = angles2.select_nth_unstable_by(middle, f64::total_cmp);
    *median / (4.0 * std::f64::consts::LN_2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{CORNER, planes_depth};
    use nalgebra::Vector3;

    /// A grid of the plane z = `depth` seen from the identity, normals towards the
    /// camera.
    fn wall(camera: &PinholeCamera, depth: f32) -> DepthGrid {
        let stride = 8u32;
        let (w, h) = (camera.width as u32 / stride, camera.height as u32 / stride);
        let mut grid = DepthGrid {
            stride_px: stride,
            width: w,
            height: h,
            ..DepthGrid::default()
        };
        for j in 0..h {
            for i in 0..w {
                let (u, v) = (
                    (i * stride + stride / 2) as f64,
                    (j * stride + stride / 2) as f64,
                );
                let x = (u - camera.cx) / camera.fx * f64::from(depth);
                let y = (v - camera.cy) / camera.fy * f64::from(depth);
                grid.points.push([x as f32, y as f32, depth]);
                grid.normals.push([0.0, 0.0, -1.0]);
            }
        }
        grid
    }

    #[test]
    fn a_corner_determines_a_pose_and_a_corridor_leaves_its_axis_free() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        let analyse = |grid: &DepthGrid| {
            gfs_optim::analyse_constraint(
                &self_information(&config, grid),
                config.lever_arm_m,
                config.max_sigma_m,
            )
        };
        let corner = planes_depth(&camera, &Isometry3::identity(), &CORNER);
        assert!(analyse(&corner).is_determined());
        let walls = [([1.0, 0.0, 0.0], -1.0), ([1.0, 0.0, 0.0], 1.0)];
        let corridor = analyse(&planes_depth(&camera, &Isometry3::identity(), &walls));
        // Free: along the corridor (z), up (y) and the roll about the walls' normal (x).
        assert_eq!(corridor.unconstrained.len(), 3, "{corridor:?}");
        for d in &corridor.unconstrained {
            assert!(
                d[0].abs() < 1e-6 && d[4].abs() < 1e-6 && d[5].abs() < 1e-6,
                "{d}"
            );
        }
    }

    #[test]
    fn tilted_normals_lend_a_wall_information_along_itself() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        let reference = wall(&camera, 2.0);
        let mut current = reference.clone();
        let pose = Isometry3::identity();
        let mut associator = DepthAssociator::default();
        associator.associate(
            &config, &camera, &current, &pose, &reference, &pose, 0.015, 1.0,
        );
        // Exact normals: nothing lent.
        assert_eq!(associator.normal_noise_information(&pose), Matrix6::zeros());
        // Every frame normal tilted by 0.02 rad: read as the median of tilts of
        // variance 0.02^2 / (4 ln 2) per component, along the wall's x and y only.
        let tilt = [0.02f32.sin(), 0.0, -0.02f32.cos()];
        current.normals.iter_mut().for_each(|n| *n = tilt);
        let pairs = associator
            .associate(
                &config, &camera, &current, &pose, &reference, &pose, 0.015, 1.0,
            )
            .to_vec();
        let h = associator.normal_noise_information(&pose);
        let w: f64 = pairs.iter().map(|o| o.inv_sigma2).sum();
        let expected = w * 0.02f64.powi(2) / (4.0 * std::f64::consts::LN_2);
        assert!(!pairs.is_empty());
        assert!((h[(0, 0)] / expected - 1.0).abs() < 1e-3, "{h}");
        assert!((h[(1, 1)] / expected - 1.0).abs() < 1e-3, "{h}");
        assert!(h[(2, 2)].abs() < 1e-9 * expected && h[(3, 3)] == 0.0, "{h}");
    }

    #[test]
    fn the_normals_noise_is_read_from_the_pairs_and_not_from_a_crease() {
        // Pairs of normals each tilted by two Gaussian components of 0.01 rad, and one
        // pair in ten across a crease (30 degrees or more apart).
        let mut rng = gfs_core::rng::SplitMix64::new(5);
        let sigma = 0.01;
        let mut angles2 = Vec::new();
        for k in 0..4000 {
            let angle2 = if k % 10 == 0 {
                (0.5 + rng.gaussian().abs()).powi(2)
            } else {
                // Their difference: two components of twice one normal's variance.
                (0..2).map(|_| 2.0 * (sigma * rng.gaussian()).powi(2)).sum()
            };
            angles2.push(angle2);
        }
        let variance = tangent_variance_from_angles(&mut angles2);
        // The creases' tenth moves the median to the chi-square's 56th percentile
        // (17 % above its median).
        assert!(
            (variance / sigma.powi(2) - 1.0).abs() < 0.25,
            "{variance} against {}",
            sigma.powi(2)
        );
        let mean = angles2.iter().sum::<f64>() / (4.0 * angles2.len() as f64);
        assert!(mean > 50.0 * sigma.powi(2), "{mean}");
        assert_eq!(tangent_variance_from_angles(&mut []), 0.0);
    }

    #[test]
    fn an_averaged_node_is_weighed_with_its_normals_tilt_across_the_pair() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        // Every third column of the wall, the rest holes: no four nodes around a pixel
        // to blend, each pair is with the node at its pixel.
        let mut reference = wall(&camera, 2.0);
        let width = reference.width as usize;
        for (k, p) in reference.points.iter_mut().enumerate() {
            if !(k % width).is_multiple_of(3) {
                *p = [0.0; 3];
            }
        }
        // The frame 2.1 cm to the side (its nodes fall between the reference's), every
        // normal tilted by 0.2 rad: read as a variance of 0.2^2 / (4 ln 2) per tangent
        // component.
        let mut current = wall(&camera, 2.0);
        let tilt = [0.2f32.sin(), 0.0, -0.2f32.cos()];
        current.normals.iter_mut().for_each(|n| *n = tilt);
        let current_from_world = Isometry3::translation(-0.021, 0.0, 0.0);
        let gate = 0.015;
        let sensor = 2.0 * kinect_depth_sigma(2.0).powi(2);
        let association = (gate / 3.0f64).powi(2);
        let mut associator = DepthAssociator::default();
        let mut pair_weights = |scale: f64| {
            associator
                .associate(
                    &config,
                    &camera,
                    &current,
                    &current_from_world,
                    &reference,
                    &Isometry3::identity(),
                    gate,
                    scale,
                )
                .iter()
                .map(|o| {
                    let offset = current_from_world.inverse() * Point3::from(o.point_in_camera);
                    let tangential2 = (offset.coords - o.surface_in_world).xy().norm_squared();
                    (o.inv_sigma2, tangential2)
                })
                .collect::<Vec<_>>()
        };
        // The Kinect model already holds the tilt: the pixel's sigma alone.
        let pixel = pair_weights(1.0);
        assert!(!pixel.is_empty());
        for (w, _) in &pixel {
            assert!((w * (sensor + association) - 1.0).abs() < 1e-9, "{w}");
        }
        // Averaged over 16 pixels: the sensor's share shrinks, the tilt across the
        // tangential offset joins it.
        let averaged = pair_weights(1.0 / 16.0);
        assert_eq!(averaged.len(), pixel.len());
        let mut offset_pairs = 0;
        for (w, tangential2) in &averaged {
            let tilt = 0.2f64.powi(2) / (4.0 * std::f64::consts::LN_2);
            let sigma2 = sensor / 16.0 + association + tangential2 * tilt;
            assert!((w * sigma2 - 1.0).abs() < 1e-6, "{w} {tangential2}");
            if *tangential2 > 1e-5 {
                offset_pairs += 1;
                assert!(*w < 1.0 / (sensor / 16.0 + association));
            }
        }
        assert!(offset_pairs > averaged.len() / 2, "{offset_pairs}");
        assert!(averaged[0].0 > 1.5 * pixel[0].0);
    }

    /// The pose information of `current` (at `camera_from_world`) from its pairs with
    /// `reference` (at `reference_from_world`), and the share of its nodes that paired.
    fn paired_information(
        camera: &PinholeCamera,
        (current, camera_from_world): (&DepthGrid, &Isometry3<f64>),
        (reference, reference_from_world): (&DepthGrid, &Isometry3<f64>),
    ) -> (Matrix6<f64>, f64) {
        let config = DepthAlignmentConfig::default();
        let mut associator = DepthAssociator::default();
        let pairs = associator.associate(
            &config,
            camera,
            current,
            camera_from_world,
            reference,
            reference_from_world,
            0.015,
            1.0,
        );
        let information = optimise_on_depth(camera, camera_from_world, pairs).information;
        (information, associator.overlap())
    }

    /// The pose optimised from `camera_from_world` on the depth pairs `pairs` alone.
    fn optimise_on_depth(
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        pairs: &[gfs_optim::DepthObservation],
    ) -> gfs_optim::PoseResult {
        let mut result = gfs_optim::PoseResult::default();
        gfs_optim::optimize_pose_with_depth(
            camera,
            camera_from_world,
            &[],
            &[],
            gfs_optim::SurfaceObservations {
                depth: pairs,
                ..gfs_optim::SurfaceObservations::default()
            },
            &gfs_optim::PoseOptimizerConfig::default(),
            &mut result,
        );
        result
    }

    #[test]
    fn a_view_turned_off_its_reference_onto_a_corner_of_its_own_needs_a_new_one() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        // A room's floor, right wall, far wall and (out of the reference's view) left
        // wall; the camera turned 30 degrees to the left sees the floor, the far wall
        // and the left wall, and pairs only on the floor and the far wall: nothing of
        // the reference holds it along x.
        let room = [
            ([0.0, 1.0, 0.0], 1.0),
            ([1.0, 0.0, 0.0], 1.2),
            ([1.0, 0.0, 0.0], -3.0),
            ([0.0, 0.0, 1.0], 4.0),
        ];
        let turned = Isometry3::rotation(nalgebra::Vector3::y() * 30f64.to_radians());
        let identity = Isometry3::identity();
        let reference = planes_depth(&camera, &identity, &room);
        let current = planes_depth(&camera, &turned, &room);
        let (information, overlap) =
            paired_information(&camera, (&current, &turned), (&reference, &identity));
        assert!(
            overlap > 0.3 && overlap < config.renewal_overlap,
            "{overlap}"
        );
        assert!(needs_new_reference(
            &config,
            &information,
            overlap,
            &current
        ));
        // Against a reference seen from where it stands, every node pairs.
        let (information, overlap) =
            paired_information(&camera, (&current, &turned), (&current, &turned));
        assert!(overlap > 0.99, "{overlap}");
        assert!(!needs_new_reference(
            &config,
            &information,
            overlap,
            &current
        ));
        // Without the side walls the turned view's own surfaces leave x free too: a
        // keyframe of it would keep whatever slide its pose has.
        let wall_and_floor = [room[0], room[3]];
        let reference = planes_depth(&camera, &identity, &wall_and_floor);
        let current = planes_depth(&camera, &turned, &wall_and_floor);
        let (information, overlap) =
            paired_information(&camera, (&current, &turned), (&reference, &identity));
        assert!(overlap < config.renewal_overlap, "{overlap}");
        assert!(!needs_new_reference(
            &config,
            &information,
            overlap,
            &current
        ));
    }

    #[test]
    fn noisy_normals_do_not_pull_a_frame_onto_the_reference_nodes() {
        // The floor and a wall 4 m ahead: their geometry leaves x free, so only the
        // normals' noise acts along it. Paired with the node at each pixel, that noise
        // pulled the frame the whole 2 cm back onto the reference's nodes.
        const WALL_AND_FLOOR: [([f64; 3], f64); 2] =
            [([0.0, 1.0, 0.0], 1.0), ([0.0, 0.0, 1.0], 4.0)];
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        let reference_pose = Isometry3::identity();
        let mut reference = planes_depth(&camera, &reference_pose, &WALL_AND_FLOOR);
        // Each reference normal tilted by up to 0.05 rad (a fixed pseudo-random
        // pattern), as block normals of a noisy sensor are.
        for (k, n) in reference.normals.iter_mut().enumerate() {
            let k = k as f32;
            let tilt = Vector3::new(0.05 * (12.99 * k).sin(), 0.05 * (78.23 * k).sin(), 0.0);
            *n = (Vector3::from(*n) + tilt).normalize().into();
        }
        // The frame 2 cm to the side (a third of a node on the wall), started there.
        let truth = Isometry3::translation(-0.02, 0.0, 0.0);
        let current = planes_depth(&camera, &truth, &WALL_AND_FLOOR);
        let mut pose = truth;
        let mut associator = DepthAssociator::default();
        for gate in &config.max_distance_m {
            let pairs = associator.associate(
                &config,
                &camera,
                &current,
                &pose,
                &reference,
                &reference_pose,
                *gate,
                1.0,
            );
            pose = optimise_on_depth(&camera, &pose, pairs).camera_from_world;
        }
        let error = (pose * truth.inverse()).translation.vector;
        assert!(error.norm() < 0.002, "{error}");
    }

    #[test]
    fn three_planes_alone_give_the_frame_to_frame_motion() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let config = DepthAlignmentConfig::default();
        let last_pose = Isometry3::identity();
        let last = planes_depth(&camera, &last_pose, &CORNER);
        // 2 cm and 1.5 degrees about a tilted axis, from the last pose as prediction.
        let truth = gfs_core::se3::exp(&nalgebra::Vector6::new(
            0.02, -0.01, 0.015, 0.01, 0.02, -0.012,
        ));
        let current = planes_depth(&camera, &truth, &CORNER);
        let mut pose = last_pose;
        let mut associator = DepthAssociator::default();
        for gate in &config.max_distance_m {
            let pairs = associator.associate(
                &config, &camera, &current, &pose, &last, &last_pose, *gate, 1.0,
            );
            pose = optimise_on_depth(&camera, &pose, pairs).camera_from_world;
        }
        let error = pose * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-3, "{error}");
        assert!(
            error.rotation.angle() < 0.1f64.to_radians(),
            "{}",
            error.rotation.angle().to_degrees()
        );
    }

    #[test]
    fn a_shifted_wall_pairs_every_node_within_the_gate_with_its_distance() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let reference = wall(&camera, 2.0);
        // The frame 2 cm closer to the wall sees it at 1.98 m.
        let current = wall(&camera, 1.98);
        let current_from_world = Isometry3::translation(0.0, 0.0, -0.02);
        let config = DepthAlignmentConfig::default();
        let mut associator = DepthAssociator::default();
        let pairs = associator.associate(
            &config,
            &camera,
            &current,
            &Isometry3::identity(),
            &reference,
            &Isometry3::identity(),
            0.05,
            1.0,
        );
        assert_eq!(pairs.len(), 40 * 30);
        for pair in pairs {
            let e = gfs_optim::residuals::PointToPlane {
                point_in_camera: pair.point_in_camera,
            }
            .error(
                &Isometry3::identity(),
                &pair.surface_in_world,
                &pair.normal_in_world,
            );
            assert!((e - 0.02).abs() < 1e-6, "{e}");
            let sigma = (2.0 * 0.0060f64.powi(2) + (0.05f64 / 3.0).powi(2)).sqrt();
            assert!((pair.inv_sigma2.sqrt().recip() - sigma).abs() < 1e-3);
            let at_truth = gfs_optim::residuals::PointToPlane {
                point_in_camera: pair.point_in_camera,
            }
            .error(
                &current_from_world,
                &pair.surface_in_world,
                &pair.normal_in_world,
            );
            assert!(at_truth.abs() < 1e-6, "{at_truth}");
        }
        // A 1 cm gate pairs nothing.
        let none = associator.associate(
            &config,
            &camera,
            &current,
            &Isometry3::identity(),
            &reference,
            &Isometry3::identity(),
            0.01,
            1.0,
        );
        assert!(none.is_empty());
    }
}
