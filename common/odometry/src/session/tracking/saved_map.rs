//! A tracking half started on a map saved by an earlier run: its first frame is placed
//! in that map (from a pose hint, or found in the whole map by the mapping half), never
//! by starting a map of its own; with a fixed map (localisation) it asks for no
//! keyframe, only for the neighbourhood of the keyframe it now refers to when that one
//! changes.

use super::TrackingSession;
use crate::frontend::features::FrameFeatures;
use crate::map::manhattan::WorldManhattan;
use crate::map::{Map, NeighbourhoodBounds};
use crate::map_file::SavedMap;
use crate::session::messages::{KeyFrameRequest, TrackedAgainst};
use crate::session::state::TrackingState;
use crate::tracking::sightings::Sightings;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// How a run uses a map loaded from a file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadedMapUse {
    /// Localisation: the map is fixed (no keyframe added, no landmark changed); each
    /// frame is tracked against it. Otherwise mapping goes on in the map's frame.
    pub localise: bool,
    /// Where the first frame is thought to be (`world_from_camera`, map frame): it is
    /// looked for around the keyframe nearest to it before the whole map is searched.
    pub initial_pose: Option<Isometry3<f64>>,
}

/// Where a session started on a saved map stands in it (kept in the checkpoint, so
/// that a restarted tracker still holds the map fixed).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub(super) struct OnSavedMap {
    /// The map is fixed: recentring requests instead of keyframe requests.
    pub fixed: bool,
    /// No frame has been placed in the map yet.
    pub unplaced: bool,
    /// The keyframe the tracker's neighbourhood was last centred on.
    pub centre: Option<KeyFrameId>,
}

impl OnSavedMap {
    /// A frame was placed in the map (found against `centre` when given).
    pub fn placed(&mut self, centre: Option<KeyFrameId>) {
        self.unplaced = false;
        if centre.is_some() {
            self.centre = centre;
        }
    }

    /// True while a lost tracker must not start a map of its own: the map is fixed, or
    /// the run has not been placed in the loaded map yet.
    pub fn keeps_map(&self) -> bool {
        self.fixed || self.unplaced
    }
}

impl TrackingSession {
    /// Starts on a map saved by an earlier run as [`crate::Odometry::start_from`] does,
    /// for a tracking half whose mapping half runs elsewhere (the `tracker` service):
    /// the neighbourhood of the keyframe nearest to `use_.initial_pose` is taken from
    /// `saved` here (the same the mapping half would send), the rest of the map dropped.
    /// Call before the first frame.
    pub fn start_on_saved(&mut self, saved: SavedMap, use_: &LoadedMapUse) {
        let mut whole = saved.map;
        whole.canonicalise();
        let bounds = NeighbourhoodBounds::of(&self.config);
        let centre = use_
            .initial_pose
            .and_then(|pose| whole.nearest_keyframe(&pose, &bounds));
        let map = match centre {
            Some(kf) => whole.neighbourhood(&whole.neighbourhood_of(kf, &bounds)),
            None => Map::default(),
        };
        self.start_on_map(map, saved.manhattan, centre, use_);
    }

    /// Starts on a map saved by an earlier run: `map` is the mapping half's
    /// neighbourhood around `centre` (the keyframe nearest to `use_.initial_pose`), or
    /// a map without keyframes when there is no hint; `manhattan` the map's axes. With
    /// a hint, the first frame is tracked from it against `centre`; without, it is lost
    /// until the mapping half finds it in the whole map. Odometry starts in the map's
    /// frame. Call before the first frame.
    pub fn start_on_map(
        &mut self,
        map: Map,
        manhattan: WorldManhattan,
        centre: Option<KeyFrameId>,
        use_: &LoadedMapUse,
    ) {
        self.map = map;
        self.map.canonicalise();
        self.manhattan = manhattan;
        self.state = TrackingState::Lost { frames: 0 };
        self.saved = OnSavedMap {
            fixed: use_.localise,
            unplaced: true,
            centre,
        };
        if let (Some(kf), Some(pose)) = (centre, use_.initial_pose) {
            self.tracker.set_reference(kf);
            let hint = TrackedFrame::untracked(FrameFeatures::default(), pose.inverse());
            self.tracker.relocalised(hint);
        }
    }

    /// With a fixed map, a tracked frame whose reference keyframe is not the one its
    /// neighbourhood is centred on, and is connected to keyframes the tracker does not
    /// hold, asks for the neighbourhood of its reference: the camera is moving into
    /// another part of the map (a map the tracker holds whole never asks). The request
    /// carries the frame without its features (nothing of it goes into the map).
    pub(super) fn recentre_request(
        &mut self,
        frame: &TrackedFrame,
        tracked: bool,
    ) -> Option<KeyFrameRequest> {
        let reference = self.tracker.reference()?;
        let due = self.saved.fixed
            && tracked
            && self.requests.pending().is_none()
            && self.saved.centre != Some(reference)
            && self
                .map
                .connected(reference)
                .iter()
                .any(|(kf, _)| self.map.keyframe(*kf).is_none());
        if !due {
            return None;
        }
        let tracked_against = TrackedAgainst {
            corrections: self.map.corrections(),
            reference,
            reference_correction: self.map.keyframe_correction(reference)?,
        };
        self.sightings = Sightings::default();
        let features = FrameFeatures {
            id: frame.features.id,
            timestamp: frame.features.timestamp,
            ..FrameFeatures::default()
        };
        Some(KeyFrameRequest {
            seq: self.requests.open(frame.features.id),
            frame: TrackedFrame::untracked(features, frame.camera_from_world),
            manhattan: self.manhattan.clone(),
            reset: false,
            sightings: Sightings::default(),
            tracked_against: Some(tracked_against),
        })
    }
}
