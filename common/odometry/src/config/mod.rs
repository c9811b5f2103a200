//! Parameters of the odometry: `[tracking]`, `[keyframes]`, `[mapping]`,
//! `[loop_closing]` tables and the ablation switches.

mod validate;

use crate::depth::alignment::DepthAlignmentConfig;
use crate::depth::noise::DepthNoise;
use crate::tracking::matching::{LineMatchConfig, PointMatchConfig};
use crate::tracking::plane_association::PlaneTrackingConfig;
use gfs_optim::{BaConfig, PoseOptimizerConfig};
use serde::Deserialize;

/// Everything the odometry is configured by.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryConfig {
    /// Tracking thresholds.
    pub tracking: TrackingConfig,
    /// Keyframe selection and culling.
    pub keyframes: KeyframeConfig,
    /// Local mapping and local BA.
    pub mapping: MappingConfig,
    /// Loop detection, verification and the pose-graph correction.
    pub loop_closing: LoopClosingConfig,
    /// The IMU's mount, noise and clock (`[imu]`), used with `[tracking] use_imu`
    /// whenever samples come.
    pub imu: gfs_inertial::ImuConfig,
}

/// `[tracking]`: frame-to-map tracking.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingConfig {
    /// Use line features in tracking and mapping (ablation switch). Default true.
    pub use_lines: bool,
    /// Use the Manhattan axes (ablation switch). Default true.
    pub use_manhattan: bool,
    /// Align the frame's depth with the last frame's in the pose optimisation
    /// (point-to-plane, `[tracking.depth]`), track on depth alone when the features
    /// fail, and flag `degraded` from the pose's information instead of an inlier count
    /// (ablation switch). Default true: where points run out (white walls, a bare
    /// floor) the depth holds the pose.
    pub use_depth_alignment: bool,
    /// Planes as landmarks: the frame's BFS planes associated with the map's planes
    /// (plane-to-plane errors in the pose optimisation), and map planes created, fused
    /// and culled with the keyframes (ablation switch). Default true.
    pub use_planes: bool,
    /// Use the IMU's samples when the caller pushes them: the prediction from their
    /// preintegration and the inertial term of the pose (ablation switch). Default true.
    pub use_imu: bool,
    /// `[tracking.planes]`: plane association gates and weights.
    pub planes: PlaneTrackingConfig,
    /// `[tracking.depth]`: the depth alignment.
    pub depth: DepthAlignmentConfig,
    /// Point matching thresholds.
    pub points: PointMatchConfig,
    /// Line matching thresholds.
    pub lines: LineMatchConfig,
    /// `[tracking.pose]`: the pose optimisation of every tracking step (rounds,
    /// iterations, chi-square thresholds, the RGB-D `bf`).
    pub pose: PoseOptimizerConfig,
    /// Inliers (points + lines) below which tracking against the local map has failed;
    /// each strategy before it needs half as many ([`Self::min_step_inliers`]).
    /// Default 25 (ORB-SLAM2 asks 30 points after local-map tracking).
    pub min_inliers: usize,
    /// Inliers a relocalisation needs. Default 40 (ORB-SLAM2 asks 50 after its final
    /// optimisation).
    pub relocalisation_min_inliers: usize,
    /// Inliers below which a tracked frame is flagged degraded. Default 60.
    pub degraded_inliers: usize,
    /// Run the line extension search when fewer map lines than this matched. Default 15.
    pub extension_search_below: usize,
    /// Keyframes of the local map tracked against. Default 20.
    pub local_keyframes: usize,
    /// Keyframes added to the local map for sharing the predicted view (camera centre
    /// within `view_radius_m`, optical axis within `view_angle_deg`), closest first, on
    /// top of the covisible ones: the landmarks of a place come back into the local map
    /// as soon as the camera looks at it again. 0 turns the view test off. Default 5.
    pub view_keyframes: usize,
    /// See `view_keyframes`; also what the mapping half adds to the tracker's
    /// neighbourhood (`[mapping] tracker_keyframes`), metres. Default 0.5.
    pub view_radius_m: f64,
    /// See `view_keyframes`, degrees. Default 30.
    pub view_angle_deg: f64,
    /// Consecutive untracked frames after which a new local map is started. Default 5.
    pub frames_before_new_map: u32,
    /// Keypoints with depth needed to start a map. Default 100.
    pub min_initial_points: usize,
    /// Depth below which a keypoint counts as close (ORB-SLAM2 `ThDepth`: 40 baselines of
    /// a Kinect, 3.1 m). Close points get map points at keyframe creation.
    pub close_depth_m: f32,
    /// Rolling-shutter readout time of the camera, first row to last, seconds; 0 for a
    /// global shutter. A camera property: filled from `[camera] readout_s`, not read
    /// from this table.
    #[serde(skip)]
    pub readout_s: f64,
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            use_lines: true,
            use_manhattan: true,
            use_depth_alignment: true,
            use_planes: true,
            use_imu: true,
            planes: PlaneTrackingConfig::default(),
            depth: DepthAlignmentConfig::default(),
            points: PointMatchConfig::default(),
            lines: LineMatchConfig::default(),
            pose: PoseOptimizerConfig::default(),
            min_inliers: 25,
            relocalisation_min_inliers: 40,
            degraded_inliers: 60,
            extension_search_below: 15,
            local_keyframes: 20,
            view_keyframes: 5,
            view_radius_m: 0.5,
            view_angle_deg: 30.0,
            frames_before_new_map: 5,
            min_initial_points: 100,
            close_depth_m: 3.1,
            readout_s: 0.0,
        }
    }
}

impl TrackingConfig {
    /// Sets the sensor's depth noise (a camera property, from `[depth] sensor`) where
    /// the depth alignment and the plane terms weigh their errors with it.
    pub fn set_depth_noise(&mut self, noise: DepthNoise) {
        self.depth.noise = noise;
        self.planes.depth_noise = noise;
    }

    /// Inliers a tracking strategy needs before local-map tracking adds its matches:
    /// half of `min_inliers` (ORB-SLAM2: 10 of 30 after the motion model).
    pub fn min_step_inliers(&self) -> usize {
        self.min_inliers / 2
    }
}

/// `[keyframes]`: selection and culling (paper "Keyframe Select and Filter").
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KeyframeConfig {
    /// A keyframe at least every this many frames (ORB-SLAM2 `mMaxFrames` = fps). Default 30.
    pub max_frames: u32,
    /// New keyframe when tracked points fall below this fraction of the reference
    /// keyframe's. Default 0.9 (ORB-SLAM2's monocular value; its RGB-D 0.75 left the
    /// points-only ATE on TUM fr1 at 0.07 m against 0.053 m, with the synthetic and
    /// 7-Scenes figures unchanged: this tracker keeps fewer inliers per frame than
    /// ORB-SLAM2, so it needs keyframes sooner).
    pub point_ratio: f32,
    /// New keyframe when tracked lines fall below this fraction of the reference
    /// keyframe's, whatever the points do (lines are less stable after homogenisation,
    /// so the threshold is lower than for points). Default 0.3: 0.5 made a keyframe of
    /// every third frame on TUM fr1_rpy (99 in 300) for the same ATE (six starts: 0.0115
    /// against 0.0118 m with 45 keyframes; 7-Scenes 0.0206 against 0.0205 m, 47 against
    /// 20 keyframes).
    pub line_ratio: f32,
    /// A keyframe is redundant when this fraction of its points is seen by at least
    /// `redundant_observers` other keyframes... Default 0.9 (ORB-SLAM2).
    pub redundant_point_fraction: f32,
    /// ... and this fraction of its lines too. Default 0.8.
    pub redundant_line_fraction: f32,
    /// Other keyframes that must see a landmark for it to count as redundant. Default 3.
    pub redundant_observers: usize,
    /// ... or this many, one of them from an earlier pass over the place (made before
    /// the last loop was closed and at least `[loop_closing] min_keyframe_gap`
    /// keyframes older): once a loop is closed the camera is known to walk mapped
    /// places again, and a keyframe made there duplicates the earlier pass's. Default 2:
    /// the 3000-frame synthetic loop then keeps 62 keyframes instead of 97, flat after
    /// the fourth lap, for the same ATE; with 2 for every keyframe (no loop needed) the
    /// low-texture rooms lost 1-1.5 mm.
    pub revisit_observers: usize,
    /// Safety cap on the keyframes of the global map, not its operating bound: the map
    /// grows with the area explored and redundant keyframes are culled, so on a room
    /// walked again and again it stays far below this. Beyond it the oldest keyframes
    /// not covisible with the new one go, so that a run that keeps exploring stays
    /// within memory and within one message: the whole map is the mapper's checkpoint
    /// and the loop stage's message, at about 90 KB a keyframe with its landmarks
    /// (640 x 480, 1000 keypoints), 500 keyframes are about 45 MB of the 64 MB a
    /// message may hold. Default 500, at most 600.
    pub max_keyframes: usize,
}

impl Default for KeyframeConfig {
    fn default() -> Self {
        Self {
            max_frames: 30,
            point_ratio: 0.9,
            line_ratio: 0.3,
            redundant_point_fraction: 0.9,
            redundant_line_fraction: 0.8,
            redundant_observers: 3,
            revisit_observers: 2,
            max_keyframes: 500,
        }
    }
}

/// `[mapping]`: landmark creation and local BA.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MappingConfig {
    /// Run the local BA after each keyframe. Default true.
    pub local_ba: bool,
    /// Covisible keyframes optimised with a new keyframe. Default 10.
    pub ba_keyframes: usize,
    /// Keyframes held fixed around the optimised ones (at most). Default 10.
    pub ba_fixed_keyframes: usize,
    /// A keyframe with fewer point observations than this in a local BA is held fixed
    /// there (a keyframe of a depth / planes-only frame); 0 holds none. Default 0.
    pub ba_min_keyframe_points: usize,
    /// At least this many closest keypoints get map points at keyframe creation, even
    /// beyond `close_depth_m`. Default 100 (ORB-SLAM2).
    pub min_new_points: usize,
    /// Angle under which two map lines count as parallel / perpendicular for the
    /// structural constraints, degrees. Default 3.
    pub structural_angle_deg: f64,
    /// Angle under which a map line is tied to a Manhattan axis, degrees. Default 6.
    pub manhattan_angle_deg: f64,
    /// Angle under which two map planes of the local BA seen by a same keyframe count
    /// as parallel / perpendicular, degrees (a pair of planes both tied to Manhattan
    /// axes within `manhattan_angle_deg` is left to those axis terms). Default 5: a
    /// plane fitted by one keyframe is 1-3 degrees off (depth noise at 2-4 m).
    pub plane_structure_angle_deg: f64,
    /// Most parallel / perpendicular pairs put into one local BA. Default 2000.
    pub max_structural_pairs: usize,
    /// Largest Hamming distance for fusing duplicate map points. Default 50.
    pub fuse_max_distance: u32,
    /// Keyframes of the map sent to the tracker with each keyframe (its neighbourhood,
    /// `MappingSession::update_around`): the new keyframe, the keyframes covisible with
    /// it and their neighbours, and those sharing its view (`[tracking] view_radius_m`,
    /// `view_angle_deg`). Bounds the map update while the global map grows. Default 60.
    pub tracker_keyframes: usize,
    /// The local BA's iterations, robust thresholds and term weights.
    pub ba: BaConfig,
}

impl Default for MappingConfig {
    fn default() -> Self {
        Self {
            local_ba: true,
            ba_keyframes: 10,
            ba_fixed_keyframes: 10,
            ba_min_keyframe_points: 0,
            min_new_points: 100,
            structural_angle_deg: 3.0,
            manhattan_angle_deg: 6.0,
            plane_structure_angle_deg: 5.0,
            max_structural_pairs: 2000,
            fuse_max_distance: 50,
            tracker_keyframes: 60,
            ba: BaConfig::default(),
        }
    }
}

/// `[loop_closing]`: coming back to a place (detection, geometric verification, pose
/// graph over the keyframes, landmark correction).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopClosingConfig {
    /// Close loops (ablation switch). Default true.
    pub enabled: bool,
    /// A candidate is at least this many keyframes older than the current one and not
    /// covisible with it (a place left and come back to, not the place being mapped).
    /// Default 20.
    pub min_keyframe_gap: u64,
    /// Keyframes after a closed loop before the next detection (the corrected map
    /// settles first). Default 10.
    pub keyframes_between_loops: u64,
    /// Candidates whose camera centre is within this distance of the current one's
    /// (in the drifted estimate), metres. Default 1.0.
    pub search_radius_m: f64,
    /// ... and whose optical axis is within this angle of the current one's, degrees.
    /// Default 40.
    pub search_angle_deg: f64,
    /// Candidates taken per keyframe from each source (appearance, position). Default 3.
    pub max_candidates: usize,
    /// Consecutive keyframes whose candidates must agree (share a keyframe of their
    /// covisible groups) before a candidate is verified (ORB-SLAM2: 3). Default 3.
    pub consistent_keyframes: u32,
    /// Point inliers of the pose optimisation that accept a loop (ORB-SLAM2: 40 after
    /// its Sim3 optimisation). Default 50.
    pub min_inliers: usize,
    /// A verified loop whose pose leaves a direction with a standard deviation above
    /// this (metres, rotations at `[tracking.depth] lever_arm_m`) is not closed: the map would be moved
    /// onto a pose its matches do not determine (far points leave a slide and a turn
    /// together). Default 0.015, as a `degraded` frame (the synthetic three laps' loop:
    /// 0.012; a loop of 55 far inliers in a low-texture room, 0.054, which moved the map
    /// 40 mm the wrong way).
    pub max_sigma_m: f64,
}

impl Default for LoopClosingConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            min_keyframe_gap: 20,
            keyframes_between_loops: 10,
            search_radius_m: 1.0,
            search_angle_deg: 40.0,
            max_candidates: 3,
            consistent_keyframes: 3,
            min_inliers: 50,
            max_sigma_m: 0.015,
        }
    }
}
