//! Loop closing: coming back to a place mapped before. After each keyframe, candidates
//! are looked for by appearance ([`place`], bag of words) and by position in the drifted
//! estimate ([`detect`]), kept when consistent over consecutive keyframes
//! ([`consistency`]), verified geometrically ([`verify`]: descriptors matched to the
//! place's points by vocabulary node, [`place_points`]), and a verified loop gives a
//! [`LoopCorrection`] ([`correct`]: a pose graph over the keyframes). Applied to the map
//! ([`correction`]), it moves the keyframes and the landmarks with them and fuses the
//! current keyframe's matches to the old side, so that tracking and local mapping go on
//! against the old landmarks.
//!
//! Detection reads the map only, so it can run apart from the mapping half that owns
//! the map: inline, the mapping half detects and applies on the same map after local
//! mapping; in the pipeline the loop stage detects and the mapper applies. The tracker
//! sees the correction in the next map it receives ([`crate::map::Map::corrections`]).

mod consistency;
mod correct;
mod correction;
mod detect;
mod place;
mod place_points;
#[cfg(test)]
mod tests;
mod verify;

pub use consistency::ConsistentGroups;
pub use correct::optimise_loop;
pub use correction::{LoopCorrection, apply_correction};
pub use detect::proximity_candidates;
pub use place::{Description, NODE_LEVEL, PlaceIndex};
pub use verify::{FrameQuery, LoopMatch, Verifier};

use crate::config::{LoopClosingConfig, OdometryConfig};
use crate::map::Map;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::pose_solver::PoseSolver;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::KeyFrameId;
use gfs_optim::analyse_constraint;
use serde::{Deserialize, Serialize};

/// A loop that was closed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoopClosure {
    /// The keyframe that came back.
    pub current: KeyFrameId,
    /// The old keyframe it closed on.
    pub candidate: KeyFrameId,
    /// Point inliers of the verification.
    pub inliers: usize,
    /// How far the correction moved the current keyframe, metres.
    pub shift_m: f64,
    /// True when the bag of words proposed the candidate, false when only its position
    /// in the drifted estimate did.
    pub by_appearance: bool,
}

/// Detects, verifies and closes loops in the map, one keyframe after the other.
pub struct LoopCloser {
    config: LoopClosingConfig,
    /// `[tracking.depth] lever_arm_m`: rotations weighed against translations when a
    /// loop's pose is checked against `max_sigma_m`, as a frame's is.
    lever_arm_m: f64,
    verifier: Verifier,
    places: PlaceIndex,
    groups: ConsistentGroups,
    last_loop: Option<KeyFrameId>,
}

impl LoopCloser {
    /// A loop closer for `camera` whose keypoints come from the pyramid `scale`.
    pub fn new(config: &OdometryConfig, camera: PinholeCamera, scale: ScalePyramid) -> Self {
        let solver = PoseSolver::new(config.tracking.pose.clone(), camera, scale);
        Self {
            config: config.loop_closing.clone(),
            lever_arm_m: config.tracking.depth.lever_arm_m,
            verifier: Verifier::new(camera, solver),
            places: PlaceIndex::default(),
            groups: ConsistentGroups::default(),
            last_loop: None,
        }
    }

    /// The keyframe of the last loop found (a restarted loop stage's checkpoint).
    pub fn last_loop(&self) -> Option<KeyFrameId> {
        self.last_loop
    }

    /// Resumes after a loop found at `kf` (no other loop for the next keyframes).
    pub fn resume(&mut self, last_loop: Option<KeyFrameId>) {
        self.last_loop = last_loop;
    }

    /// Looks for a loop at keyframe `kf` (just mapped) and returns the correction of
    /// the first verified one, or `None` (disabled, too soon after the last loop, no
    /// candidate, none verified, or the pose graph failed). The map is not changed:
    /// [`apply_correction`] does that.
    pub fn after_keyframe(&mut self, map: &Map, kf: KeyFrameId) -> Option<LoopCorrection> {
        if !self.config.enabled {
            return None;
        }
        self.places.sync(map);
        if let Some(last) = self.last_loop
            && kf.0 < last.0 + self.config.keyframes_between_loops
        {
            self.groups.clear();
            return None;
        }
        let by_appearance = self.places.candidates(map, kf, &self.config);
        let mut candidates = by_appearance.clone();
        for near in proximity_candidates(map, kf, &self.config) {
            if !candidates.contains(&near) {
                candidates.push(near);
            }
        }
        let consistent = self
            .groups
            .update(map, &candidates, self.config.consistent_keyframes);
        let start = std::time::Instant::now();
        let mut verified = 0;
        let found = consistent.iter().find_map(|&candidate| {
            verified += 1;
            let found = self.verifier.verify(
                map,
                &self.places,
                kf,
                candidate,
                self.config.min_inliers,
                kf.0,
            )?;
            let constraint = analyse_constraint(
                &found.information,
                self.lever_arm_m,
                self.config.max_sigma_m,
            );
            if !constraint.is_determined() {
                tracing::debug!(
                    keyframe = %kf,
                    %candidate,
                    inliers = found.inliers,
                    pose_sigma_m = constraint.worst_sigma_m,
                    "loop not closed: its pose is not determined"
                );
                return None;
            }
            Some(found)
        });
        if verified > 0 {
            tracing::debug!(
                keyframe = %kf,
                candidates = candidates.len(),
                verified,
                found = found.is_some(),
                ms = start.elapsed().as_secs_f64() * 1e3,
                "loop candidates verified"
            );
        }
        let found = found?;
        let poses = match optimise_loop(map, kf, &found) {
            Ok(poses) => poses,
            Err(e) => {
                tracing::warn!(keyframe = %kf, candidate = %found.candidate, "loop not corrected: {e}");
                return None;
            }
        };
        self.last_loop = Some(kf);
        self.groups.clear();
        Some(LoopCorrection {
            current: kf,
            candidate: found.candidate,
            inliers: found.inliers,
            by_appearance: by_appearance.contains(&found.candidate),
            poses,
            matches: found
                .point_ids
                .iter()
                .enumerate()
                .filter_map(|(i, old)| old.map(|old| (i, old)))
                .collect(),
            map_corrections: map.corrections(),
        })
    }
}
