//! Projective point-to-plane association of a frame's depth with the last frame's
//! (the depth geometry term of tracking, where features are too few to hold the pose).
//!
//! The reference is the last frame's depth, the nearest view: a real sensor's depth error
//! is correlated from view to view (and its depth is not taken with the colour image),
//! which consecutive frames share. With `[tracking.depth] keyframe_reference` (a sensor
//! whose noise is independent from frame to frame, as `gfsvo synth` renders) it is the
//! newest keyframe's depth at its pose in the map: frame-to-keyframe, the depth term does
//! not add up the frames' errors as frame-to-frame alignment does, and the local BA's
//! refinements of the keyframe reach the frame; the last frame serves when the keyframe's
//! depth was not kept (a keyframe made of an earlier frame than the last, as in the
//! realtime pipeline).
//!
//! Each sampled node `q` of the frame's [`DepthGrid`] is moved into the reference with
//! the current estimate, projected, and paired with the reference's surface at that
//! pixel (its four nodes around it blended, [`DepthGrid::surface_at_pixel`]) when they
//! are close and their normals agree; a node on one of the frame's planes is paired
//! along that plane's normal ([`DepthAssociator::set_frame_planes`]). The distance is
//! weighed with the depth noise of both ends as the sensor's family gives it
//! ([`DepthNoise`], `[depth] sensor`), averaged over a node's block where the sensor's
//! noise is independent from pixel to pixel
//! ([`DepthAlignmentConfig::independent_pixels_per_node`]).

use crate::depth::grid::DepthGrid;
use crate::depth::noise::DepthNoise;
use gfs_optim::residuals::PointToPlane;
use nalgebra::{Isometry3, Matrix3, Matrix6};
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
    /// default 0.004 (always: TUM fr1 0.0151 m and 7-Scenes 0.0344 m instead of 0.0115
    /// and 0.0208 m, the real depth's bias weighs against well-placed features; 0.002
    /// with the depth noise of the sensor family took 7-Scenes' first 300 frames from
    /// 16.77 to 22.27 mm, the Kinect-like low-texture rooms within 0.03 mm either way).
    pub weak_sigma_m: f64,
    /// Align with the depth of the newest keyframe (at its pose in the map, while the map
    /// holds it) instead of the last frame's; default false. Frame to keyframe, the
    /// frames' errors do not add up, but a real sensor's depth error, correlated between
    /// views and unsynchronised with the colour image, does not cancel across a
    /// keyframe's baseline: TUM fr1 and 7-Scenes over six start frames with all terms
    /// 14.63 / 25.33 mm against 12.52 / 21.10 mm from the last frame. `gfsvo synth`
    /// writes true for its noise, independent from frame to frame (its 24 low-texture
    /// sequences with all terms 2.13 mm, 21 within 4 mm, against 4.24 mm, 15).
    pub keyframe_reference: bool,
    /// With `keyframe_reference`: the keyframe's intensity cells become the mean of its
    /// own and the views of the frames `Tracked` against it (up to 8 views a cell),
    /// brought onto its cells through its depth at its exposure
    /// (`reference_intensity.rs`); default true. The synthetic low-texture seeds 1-28
    /// with all terms: 79 -> 82 of 84 within 4 mm with every frame tracked, with depth
    /// alone 76 -> 81 (the photometric samples weighed as before; weighed by the noise
    /// the averaging leaves, 82 and 79; the record's "The keyframe's intensities
    /// averaged over its frames").
    pub average_reference_views: bool,
    /// Standard deviation of the photometric term's intensity difference (blurred 4 px
    /// cell means), gray levels; 0 = no photometric term; default 0.5 (a camera's 2
    /// gray levels of pixel noise leave about 0.15 on the difference of two such
    /// cells; with the motion prior, 0.4-0.6 took the synthetic low-texture rotation
    /// seed 1 to 7-18 mm, 1.0 to 16-31 mm). Samples at every node (`source_step` 1)
    /// are 8 px apart on cells blurred over 16 px and share their noise: on `gfsvo
    /// synth`'s images they differ by 0.12-0.13 gray levels at the true pose, 0.25-0.29
    /// counted with their correlation, and it writes 0.4 (its 24 low-texture sequences
    /// with all terms: 0.25 / 0.4 / 0.7: 2.16 / 2.10 / 2.15 mm, 22 within 4 mm each).
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
    /// this (`crate::tracking::motion_prior::FilteredVelocity`); default 4 (the 24 synthetic
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
    /// fixing a pose within `renewal_own_sigma_m`, becomes a keyframe: the depth
    /// reference is renewed while the frame is still `tracked`, before the view leaves
    /// it (a `degraded` frame without points makes none, and in a room without
    /// keypoints no other rule asks for one in time); 0 = never. The keyframe keeps the
    /// frame's error, and the frame is the least determined of those since the last
    /// renewal: default 0.004 (0.006 until 2026-11-28: the 24 synthetic low-texture
    /// sequences with all terms 20 -> 21 within 4 mm, fast 2 5.1 -> 3.2 mm, rotation 6
    /// 3.8 -> 2.5 mm, rotation 1 6.5 -> 10.7 mm; 0.003: 21, rotation 1 12.2 mm; 0:
    /// 18).
    pub renewal_sigma_m: f64,
    /// The worst standard deviation (metres at the lever arm) a renewing frame's own
    /// surfaces must determine its pose within ([`self_information`]): a frame of one
    /// wall, whose slide a new reference would keep, does not renew; default 0.006
    /// (the 24 sequences with all terms 5.78 -> 5.38 mm when the rule came, rotation
    /// seeds 4 and 6 7.6 / 11.1 -> 3.5 / 3.7 mm with every frame `tracked`).
    pub renewal_own_sigma_m: f64,
    /// Share of a frame's depth nodes paired with the reference below which its view
    /// has moved off the reference (`renewal_sigma_m`); default 0.85 (where most nodes
    /// pair, a weak direction is the surfaces', which a new reference does not fix:
    /// with 1.0 the 24 sequences' mean went to 5.56 mm, slow 5 22.3 -> 27.7 mm).
    pub renewal_overlap: f64,
    /// Share of a `degraded` frame's depth nodes paired with the reference below which
    /// the reference is leaving its view: the frame becomes a keyframe whatever its own
    /// surfaces fix (`renewal_sigma_m` 0 turns this off too); default 0.5 (unseen fast
    /// seed 27 with all terms: 10.0 mm, 39 frames `degraded`, -> 3.8 mm, 8; at 0.3: 4.2
    /// mm, 12).
    pub renewal_floor_overlap: f64,
    /// Estimate the colour camera's vignetting from the tracked frames and divide it out
    /// of each frame's intensities before the photometric term reads them
    /// (`vignetting.rs`); default true (a Kinect-like camera with 30 % falloff turning
    /// in a bare room: 466 mm ATE without, every frame `tracked`).
    pub estimate_vignetting: bool,
    /// Association gates of the coarse registration, metres: a frame the motion model
    /// landed far from (a jump of 0.15 m / 7 degrees that neither the features nor the
    /// geometry tracked from the prediction) is aligned with the reference's depth
    /// without the motion prior, one re-association and pose optimisation per entry,
    /// then tracked on its geometry from there; empty = such a frame is lost; default
    /// [0.4, 0.3, 0.2, 0.12] (a turn of 7 degrees moves a wall 3 m away by 0.37 m).
    pub registration_distance_m: Vec<f64>,
    /// The sensor's depth noise: a camera property, filled from `[depth] sensor`, not
    /// read from this table.
    #[serde(skip)]
    pub noise: DepthNoise,
}

impl Default for DepthAlignmentConfig {
    fn default() -> Self {
        Self {
            source_step: 2,
            max_distance_m: vec![0.08, 0.03, 0.015],
            max_normal_angle_deg: 30.0,
            lever_arm_m: 2.0,
            max_sigma_m: 0.015,
            weak_sigma_m: 0.004,
            keyframe_reference: false,
            average_reference_views: true,
            photometric_sigma: 0.5,
            photometric_position_sigma_px: 1.0,
            photometric_on_features: false,
            motion_prior_accel_m_s2: 12.0,
            motion_prior_angular_accel_deg_s2: 800.0,
            motion_prior_feature_angular_accel_deg_s2: 3200.0,
            motion_prior_velocity_accel_m_s2: 4.0,
            motion_prior_angular_rate_accel_deg_s2: 200.0,
            independent_pixels_per_node: 1.0,
            renewal_sigma_m: 0.004,
            renewal_own_sigma_m: 0.006,
            renewal_overlap: 0.85,
            renewal_floor_overlap: 0.5,
            estimate_vignetting: true,
            registration_distance_m: vec![0.4, 0.3, 0.2, 0.12],
            noise: DepthNoise::default(),
        }
    }
}

impl DepthAlignmentConfig {
    /// Depth difference, metres, past which a point seen from another view is on
    /// another surface (occluded or disoccluded): the coarsest association gate.
    pub fn occlusion_m(&self) -> f64 {
        self.max_distance_m.first().copied().unwrap_or(0.08)
    }
}

/// The information a frame's depth would give its own pose, were every sampled node
/// paired with itself: whether its surfaces can determine a pose at all (a frame of
/// one wall cannot). Less, with `normal_variance` > 0 (rad^2 per tangent direction,
/// [`DepthAssociator::normal_variance`]), what its normals' noise lends it along its
/// surfaces, as [`DepthAssociator::normal_noise_information`] takes it out of a pose's:
/// with their noise in, the nodes of `gfsvo synth`'s bare walls hold their own slide to
/// 4-5 mm.
pub fn self_information(
    config: &DepthAlignmentConfig,
    grid: &DepthGrid,
    normal_variance: f64,
) -> Matrix6<f64> {
    let mut h = Matrix6::zeros();
    let step = config.source_step.max(1);
    let width = grid.width as usize;
    for j in (step / 2..grid.height as usize).step_by(step) {
        for i in (step / 2..width).step_by(step) {
            if let Some((q, n)) = grid.node(j * width + i) {
                let w = 1.0 / (2.0 * config.noise.sigma(q.z).powi(2));
                let l =
                    PointToPlane { point_in_camera: q }.linearize(&Isometry3::identity(), &q, &n);
                h += l.d_pose.transpose() * l.d_pose * w;
                let tangent = Matrix3::identity() - n * n.transpose();
                let mut translation = h.fixed_view_mut::<3, 3>(0, 0);
                translation -= tangent * (w * normal_variance);
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
    moving_off_reference(config, overlap)
        && worst_sigma_m(config, pose_information) > config.renewal_sigma_m
        && worst_sigma_m(config, &self_information(config, grid, 0.0)) < config.renewal_own_sigma_m
}

/// Whether a `degraded` frame tracked on its depth (`grid`, of which `overlap` is the
/// share of nodes paired with the reference, its normals' tilt variance
/// `normal_variance`) should renew its depth reference: it is moving off the reference
/// (`overlap` below `renewal_overlap`) and its own surfaces, less what their normals'
/// noise lends them, fix a pose within `renewal_own_sigma_m` (a corner the reference
/// does not hold; a bare wall's slide, or two walls' along their edge, stays free), or
/// the reference is leaving its view (`overlap` below `renewal_floor_overlap`). A
/// `degraded` frame that never renewed stayed `degraded` while its view turned onto a
/// corner of its own, or was lost once the reference left it (unseen fast seeds 28 and
/// 27: 44 and 39 frames `degraded`).
pub fn degraded_frame_renews(
    config: &DepthAlignmentConfig,
    overlap: f64,
    grid: &DepthGrid,
    normal_variance: f64,
) -> bool {
    moving_off_reference(config, overlap)
        && (overlap < config.renewal_floor_overlap
            || worst_sigma_m(config, &self_information(config, grid, normal_variance))
                < config.renewal_own_sigma_m)
}

/// With the renewal on, whether a view pairing `overlap` of its nodes with the
/// reference is moving off it.
fn moving_off_reference(config: &DepthAlignmentConfig, overlap: f64) -> bool {
    config.renewal_sigma_m > 0.0 && overlap < config.renewal_overlap
}

/// The standard deviation of the direction `information` holds least, metres at the
/// lever arm.
fn worst_sigma_m(config: &DepthAlignmentConfig, information: &Matrix6<f64>) -> f64 {
    gfs_optim::analyse_constraint(information, config.lever_arm_m, config.max_sigma_m).worst_sigma_m
}

mod associator;
#[cfg(test)]
mod tests;

pub use associator::DepthAssociator;
