//! The depth term of tracking (`[tracking] use_depth_alignment`): the frame's depth
//! aligned with the reference keyframe's (or the last frame's), point to plane, inside
//! the pose optimisation; and the frame's status from what the combined constraints
//! determine.

use super::{TrackedFrame, Tracker};
use crate::depth::alignment::{DepthAlignmentConfig, degraded_frame_renews, needs_new_reference};
use crate::depth::grid::{DepthGrid, IntensityLevel, PosedGrid};
use crate::map::Map;
use crate::tracking::motion_prior::{PriorFor, motion_prior};
use crate::tracking::status::TrackingStatus;
use gfs_core::ids::KeyFrameId;
use gfs_core::stamp::Stamp;
use gfs_optim::analyse_constraint;
use gfs_optim::residuals::PosePrior;
use nalgebra::{Isometry3, Matrix6};

/// Share of the associated depth pairs that must stay inliers for a frame tracked on
/// depth alone: below it the prediction was too far off for the association.
const MIN_DEPTH_INLIER_SHARE: f64 = 0.5;
/// The coarse registration's prior around the motion model's prediction, metres and
/// degrees per axis: wide enough for a jump of 0.15 m / 7 degrees, it holds the
/// directions the first, widest pairs leave free (a turn moves a side wall beyond the
/// gate: its slide is free until the turn is found).
const REGISTRATION_PRIOR_M: f64 = 0.2;
const REGISTRATION_PRIOR_DEG: f64 = 10.0;
/// Longest interval from a tracked last frame that tracking on geometry and the coarse
/// registration bridge, seconds (three frames at 30 Hz).
const MAX_REGISTRATION_INTERVAL_S: f64 = 0.1;

impl Tracker {
    /// Re-optimises a frame tracked on features with the depth pairs added, in the
    /// coarse-to-fine passes of `[tracking.depth] max_distance_m`; skipped when the
    /// features alone constrain every direction within `weak_sigma_m`. False when the
    /// depth could not be used (no depth, no last frame).
    pub(super) fn refine_with_depth(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        let depth = &self.config.depth;
        if depth.weak_sigma_m > 0.0
            && analyse_constraint(
                self.solver.information(),
                depth.lever_arm_m,
                depth.weak_sigma_m,
            )
            .is_determined()
        {
            return false;
        }
        self.solver.set_prior(self.motion_prior(PriorFor::Features));
        let sensor_variance_scale = 1.0 / self.config.depth.independent_pixels_per_node;
        let aligned = self.align_depth(
            map,
            frame,
            Gates::Tracking,
            self.config.depth.photometric_on_features,
            sensor_variance_scale,
            IntensityLevel::Cells,
        );
        self.solver.set_prior(None);
        aligned
    }

    /// Tracks a frame the features lost on its planes and depth alone (each when
    /// switched on), from its current pose and matches, the photometric term reading
    /// the intensities at `level`; true when enough depth pairs held, or planes did. A
    /// direction they leave free stays where the motion prior holds it (a bare wall's
    /// slide): what they determine is measured all the same, and the frame's status and
    /// covariance say what they left free.
    pub(super) fn track_on_geometry(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        level: IntensityLevel,
    ) -> bool {
        self.solver.set_prior(self.motion_prior(PriorFor::Geometry));
        if self.config.use_planes {
            self.refine_with_planes(map, frame);
        }
        let depth_ok = self.config.use_depth_alignment
            && self.align_depth(map, frame, Gates::Tracking, true, 1.0, level)
            && frame.inliers.depth > 0
            && frame.inliers.depth as f64 >= MIN_DEPTH_INLIER_SHARE * self.depth_pairs as f64;
        self.keep_plane_inliers(frame);
        self.clear_planes();
        self.solver.set_prior(None);
        depth_ok || frame.inliers.planes > 0
    }

    /// The coarse-to-fine association and optimisation passes of `gates`, against the
    /// reference keyframe's depth or the last frame's ([`depth_reference`]), the nodes'
    /// sensor variance scaled by `sensor_variance_scale`, the photometric term (with
    /// `photometric`) on the intensities at `level`.
    fn align_depth(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        gates: Gates,
        photometric: bool,
        sensor_variance_scale: f64,
        level: IntensityLevel,
    ) -> bool {
        self.depth_associator
            .set_frame_planes(&frame.features.planes);
        for pass in 0..gates.of(&self.config.depth).len() {
            let gate = gates.of(&self.config.depth)[pass];
            let Some((reference, reference_from_world)) = depth_reference(
                self.config.depth.keyframe_reference,
                self.keyframe_depth.as_ref(),
                self.last.as_ref(),
                map,
            ) else {
                return false;
            };
            if frame.features.depth.is_empty() {
                return false;
            }
            let pairs = self.depth_associator.associate(
                &self.config.depth,
                &self.camera,
                PosedGrid {
                    grid: &frame.features.depth,
                    camera_from_world: &frame.camera_from_world,
                },
                PosedGrid {
                    grid: reference,
                    camera_from_world: &reference_from_world,
                },
                gate,
                sensor_variance_scale,
            );
            self.depth_pairs = pairs.len();
            self.solver.set_depth(pairs);
            let observations = self.photometric_associator.associate(
                &self.config.depth,
                &self.camera,
                PosedGrid {
                    grid: &frame.features.depth,
                    camera_from_world: &frame.camera_from_world,
                },
                PosedGrid {
                    grid: reference,
                    camera_from_world: &reference_from_world,
                },
                level,
            );
            self.solver
                .set_photometric(if photometric { observations } else { &[] }, level);
            self.optimise(map, frame);
        }
        self.solver.set_depth(&[]);
        self.solver.set_photometric(&[], IntensityLevel::Cells);
        true
    }

    /// The frame's prediction as a prior, for a frame tracked on `tracked_on`: where the
    /// filtered velocity takes the last frame ([`crate::tracking::motion_prior::FilteredVelocity`]).
    fn motion_prior(&self, tracked_on: PriorFor) -> Option<PosePrior> {
        let dt = self.predicted_over_s?;
        let predicted = self.velocity_filter.predict(&self.predicted, dt);
        motion_prior(&self.config.depth, &predicted, dt, tracked_on)
    }

    /// Keeps the depth of `frame`, of which a keyframe was just requested, until the
    /// map holds that keyframe: in realtime the map's answer may come after the next
    /// frames are tracked, when the last frame is no longer the keyframe's.
    pub fn keep_requested_keyframe_depth(&mut self, frame: &TrackedFrame) {
        if !self.config.use_depth_alignment
            || !self.config.depth.keyframe_reference
            || frame.features.depth.is_empty()
        {
            return;
        }
        let (requested, grid) = &mut self.requested_keyframe_depth;
        grid.clone_from(&frame.features.depth);
        *requested = Some(frame.features.id);
    }

    /// Holds the requested keyframe's depth once the reference is that keyframe (a
    /// keyframe does not keep its depth in the map). Called before every frame, so
    /// that each keyframe's depth is held, not only that of a keyframe whose next frame
    /// needed the depth.
    pub(super) fn hold_keyframe_depth(&mut self, map: &Map) {
        let (requested, grid) = &mut self.requested_keyframe_depth;
        let (Some(reference), Some(frame)) = (self.reference, *requested) else {
            return;
        };
        if map
            .keyframe(reference)
            .is_some_and(|k| k.features.id == frame)
        {
            *requested = None;
            let depth = std::mem::take(grid);
            // The depth held before becomes the next request's buffer.
            if let Some((_, before)) = self.keyframe_depth.replace((reference, depth)) {
                self.requested_keyframe_depth.1 = before;
            }
        }
    }

    /// Averages the view of `frame`, `Tracked` against the newest keyframe's depth, into
    /// that keyframe's intensities ([`crate::depth::reference_intensity`]) with `[tracking.depth]
    /// average_reference_views`. Not between images too clean to be dithered: their
    /// rounding contours, which a change of exposure moves, would be averaged.
    pub(super) fn add_view_to_reference(&mut self, map: &Map, frame: &TrackedFrame) {
        let depth = &self.config.depth;
        if !depth.average_reference_views
            || frame.status != TrackingStatus::Tracked
            || !frame.features.depth.rounding_is_dithered()
        {
            return;
        }
        let Some((kf, grid)) =
            (self.keyframe_depth.as_mut()).filter(|(_, grid)| grid.rounding_is_dithered())
        else {
            return;
        };
        let Some(keyframe) = map.keyframe(*kf) else {
            return;
        };
        let occlusion_m = depth.occlusion_m();
        self.reference_intensity.add_view(
            &self.camera,
            *kf,
            grid,
            &keyframe.camera_from_world,
            PosedGrid {
                grid: &frame.features.depth,
                camera_from_world: &frame.camera_from_world,
            },
            occlusion_m,
        );
    }

    /// Adds `frame`, when `Tracked`, and the last frame to the vignetting estimate
    /// (`[tracking.depth] estimate_vignetting`).
    pub(super) fn observe_vignetting(&mut self, frame: &TrackedFrame) {
        if !self.config.use_depth_alignment || !self.config.depth.estimate_vignetting {
            return;
        }
        if frame.status == TrackingStatus::Tracked
            && let Some(last) = &self.last
        {
            self.vignetting.observe(
                &self.camera,
                PosedGrid {
                    grid: &frame.features.depth,
                    camera_from_world: &frame.camera_from_world,
                },
                PosedGrid {
                    grid: &last.features.depth,
                    camera_from_world: &last.camera_from_world,
                },
                self.config.depth.occlusion_m(),
            );
        }
        self.vignetting.next_frame();
    }

    /// Tracks a frame the features lost on its geometry ([`Self::track_on_geometry`]),
    /// the photometric term on the intensity cells and, where they leave the pose
    /// undetermined or a direction weak (the motion prior placed the pose along it),
    /// again from there on the coarse intensities, whose gradients hold a paint coarser
    /// than the cells that the cells' noise hides. `Tracked` when a level determines
    /// the pose, `Degraded` when one tracked it with a direction left weak, `None` when
    /// neither tracked it.
    pub(super) fn track_on_geometry_levels(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
    ) -> Option<TrackingStatus> {
        let on_cells = self.track_on_geometry(map, frame, IntensityLevel::Cells);
        if on_cells && !self.leaves_weak_directions(&frame.camera_from_world) {
            return Some(TrackingStatus::Tracked);
        }
        let has_coarse = self.config.use_depth_alignment
            && self.config.depth.photometric_sigma > 0.0
            && (frame.features.depth)
                .intensity_grid(IntensityLevel::Coarse)
                .is_some();
        let on_coarse = has_coarse && self.track_on_geometry(map, frame, IntensityLevel::Coarse);
        if on_coarse && !self.leaves_weak_directions(&frame.camera_from_world) {
            Some(TrackingStatus::Tracked)
        } else {
            (on_cells || on_coarse).then_some(TrackingStatus::Degraded)
        }
    }

    /// Tracks a frame the features lost on its geometry from `predicted`
    /// ([`Self::track_on_geometry_levels`]); when that leaves the pose weak or fails,
    /// the frame may be far from the prediction and is registered coarse to fine
    /// ([`Self::register_far_frame`]). A registration that determines the pose wins;
    /// otherwise a frame the geometry tracked from the prediction is tracked so again
    /// (`Degraded`: the prior held what its geometry left free), and one it did not
    /// keeps the registration's status.
    pub(super) fn track_on_geometry_or_register(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        predicted: &Isometry3<f64>,
    ) -> Option<TrackingStatus> {
        let from_prediction = self.track_on_geometry_levels(map, frame);
        if from_prediction == Some(TrackingStatus::Tracked) {
            return from_prediction;
        }
        let predicted_over_s = self.predicted_over_s;
        let registered = self.register_far_frame(map, frame, predicted);
        if registered == Some(TrackingStatus::Tracked) || from_prediction.is_none() {
            return registered;
        }
        self.predicted_over_s = predicted_over_s;
        frame.restart(predicted);
        frame.inliers = Default::default();
        self.keep_few_matches(map, frame, predicted);
        self.track_on_geometry_levels(map, frame)
    }

    /// Registers a frame the motion model landed far from, which neither its features
    /// nor its geometry tracked from `predicted`, the last frame tracked and recent,
    /// coarse to fine: its depth alone is
    /// aligned with the reference's through the wide gates of `[tracking.depth]
    /// registration_distance_m`, without the motion prior (whose prediction was wrong),
    /// and the frame is tracked on its geometry from there, still without the prior. The
    /// status as [`Self::track_on_geometry_levels`] gives it; `None` when the coarse
    /// pairs do not hold (fewer than half of them inliers) or the fine tracking fails.
    pub(super) fn register_far_frame(
        &mut self,
        map: &Map,
        frame: &mut TrackedFrame,
        predicted: &Isometry3<f64>,
    ) -> Option<TrackingStatus> {
        if !self.config.use_depth_alignment
            || self.config.depth.registration_distance_m.is_empty()
            || !self.last_frame_is_recent(frame.features.timestamp)
        {
            return None;
        }
        frame.restart(predicted);
        frame.inliers = Default::default();
        self.solver.set_prior(Some(PosePrior::isotropic(
            *predicted,
            REGISTRATION_PRIOR_M,
            REGISTRATION_PRIOR_DEG.to_radians(),
        )));
        let aligned = self.align_depth(
            map,
            frame,
            Gates::Registration,
            false,
            1.0,
            IntensityLevel::Cells,
        );
        let held = frame.inliers.depth > 0
            && frame.inliers.depth as f64 >= MIN_DEPTH_INLIER_SHARE * self.depth_pairs as f64;
        if !aligned || !held {
            return None;
        }
        self.solver.set_prior(None);
        self.predicted_over_s = None;
        self.track_on_geometry_levels(map, frame)
    }

    /// Whether the last frame was tracked, at most [`MAX_REGISTRATION_INTERVAL_S`] before
    /// `stamp`: after frames without a pose (the camera blind or skipped) its depth is of another
    /// view, and tracking on geometry against it would find a wall or a floor anywhere.
    pub(super) fn last_frame_is_recent(&self, stamp: Stamp) -> bool {
        self.last.as_ref().is_some_and(|l| {
            l.status.is_tracked()
                && stamp.secs_since(l.features.timestamp) <= MAX_REGISTRATION_INTERVAL_S
        })
    }

    /// True when the last optimisation's information, less what the depth pairs' normal
    /// noise lends it, leaves a direction with a standard deviation above `[tracking.
    /// depth] max_sigma_m`, for a frame at `camera_from_world`.
    pub(super) fn leaves_weak_directions(&self, camera_from_world: &Isometry3<f64>) -> bool {
        let depth = &self.config.depth;
        !analyse_constraint(
            &self.information_less_normal_noise(camera_from_world),
            depth.lever_arm_m,
            depth.max_sigma_m,
        )
        .is_determined()
    }

    /// Whether `frame`, just tracked with depth pairs, has moved off its depth reference
    /// and should become a keyframe: when `Tracked`, [`needs_new_reference`]; when
    /// `Degraded`, [`degraded_frame_renews`].
    pub fn leaves_depth_reference(&self, frame: &TrackedFrame) -> bool {
        if frame.inliers.depth == 0 {
            return false;
        }
        let (config, overlap) = (&self.config.depth, self.depth_associator.overlap());
        match frame.status {
            TrackingStatus::Tracked => needs_new_reference(
                config,
                &self.information_less_normal_noise(&frame.camera_from_world),
                overlap,
                &frame.features.depth,
            ),
            TrackingStatus::Degraded => degraded_frame_renews(
                config,
                overlap,
                &frame.features.depth,
                self.depth_associator.normal_variance(),
            ),
            TrackingStatus::Predicted | TrackingStatus::Relocalised => false,
        }
    }

    /// What the last optimisation's data determined of `frame`'s pose: less the normals'
    /// noise where its depth was paired (the associator's state is another frame's
    /// otherwise).
    pub(super) fn determined_information(&self, frame: &TrackedFrame) -> Matrix6<f64> {
        if frame.inliers.depth > 0 {
            self.information_less_normal_noise(&frame.camera_from_world)
        } else {
            *self.solver.information()
        }
    }

    /// The last optimisation's information less what the depth pairs' normal noise
    /// lends it, for a frame at `camera_from_world`.
    fn information_less_normal_noise(&self, camera_from_world: &Isometry3<f64>) -> Matrix6<f64> {
        let information = *self.solver.information();
        if self.depth_pairs == 0 {
            return information;
        }
        information
            - self
                .depth_associator
                .normal_noise_information(camera_from_world, self.solver.depth_inliers())
    }

    /// `Degraded` when the last optimisation's information leaves a pose direction
    /// with a standard deviation above `[tracking.depth] max_sigma_m`, else `Tracked`.
    pub(super) fn status_from_information(&self) -> TrackingStatus {
        let depth = &self.config.depth;
        let constraint = analyse_constraint(
            self.solver.information(),
            depth.lever_arm_m,
            depth.max_sigma_m,
        );
        tracing::debug!(
            worst_sigma_m = constraint.worst_sigma_m,
            pairs = self.depth_pairs,
            "pose constraint"
        );
        if constraint.is_determined() {
            TrackingStatus::Tracked
        } else {
            TrackingStatus::Degraded
        }
    }
}

/// Which association gates a run of [`Tracker::align_depth`] passes through.
#[derive(Clone, Copy)]
enum Gates {
    /// `[tracking.depth] max_distance_m`: from a prediction within a few centimetres.
    Tracking,
    /// `[tracking.depth] registration_distance_m`: from a prediction far off.
    Registration,
}

impl Gates {
    fn of(self, config: &DepthAlignmentConfig) -> &[f64] {
        match self {
            Self::Tracking => &config.max_distance_m,
            Self::Registration => &config.registration_distance_m,
        }
    }
}

/// The depth the frame is aligned with, and its pose: with `[tracking.depth]
/// keyframe_reference`, the newest keyframe's while the map holds it (at its pose there,
/// which the local BA refines: the frame is tied to the map, not to the last frame's
/// drift), also when the points' reference has moved to an older keyframe; else the last
/// frame's.
fn depth_reference<'a>(
    keyframe_reference: bool,
    keyframe_depth: Option<&'a (KeyFrameId, DepthGrid)>,
    last: Option<&'a TrackedFrame>,
    map: &Map,
) -> Option<(&'a DepthGrid, Isometry3<f64>)> {
    if keyframe_reference
        && let Some((kf, grid)) = keyframe_depth
        && let Some(keyframe) = map.keyframe(*kf)
    {
        return Some((grid, keyframe.camera_from_world));
    }
    let last = last?;
    (!last.features.depth.is_empty()).then_some((&last.features.depth, last.camera_from_world))
}

#[cfg(test)]
mod tests;
