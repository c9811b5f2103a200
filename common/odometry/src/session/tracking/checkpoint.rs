//! What a restarted tracker resumes from: the tracking half's state without the map,
//! which comes from the mapper (the `tracker` service writes it after every frame).

use super::TrackingSession;
use crate::map::manhattan::WorldManhattan;
use crate::session::messages::MapUpdate;
use crate::session::state::{RequestLedger, TrackingState};
use crate::tracking::motion::MotionModel;
use crate::tracking::sightings::Sightings;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// What a restarted tracker needs to go on where the old one stopped (the map comes
/// from the mapper).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct TrackingCheckpoint {
    /// The state machine.
    pub state: TrackingState,
    /// The request numbering and the map tracked against.
    pub requests: RequestLedger,
    /// The last frame processed, with its features and landmark links.
    pub last: Option<TrackedFrame>,
    /// The motion model.
    pub motion: MotionModel,
    /// The reference keyframe.
    pub reference: Option<KeyFrameId>,
    /// Frames since the last keyframe.
    pub frames_since_keyframe: u32,
    /// Landmark sightings not reported yet (the mapper culls on them).
    pub sightings: Sightings,
    /// The world Manhattan axes.
    pub manhattan: WorldManhattan,
    /// The loop corrections so far, `map_from_odom`.
    #[serde(default = "Isometry3::identity")]
    pub map_from_odom: Isometry3<f64>,
    /// Where the run stands in a map it was started on (a fixed map stays fixed).
    #[serde(default)]
    pub(super) saved: super::saved_map::OnSavedMap,
}

impl TrackingSession {
    /// The state a restarted tracker resumes from (with a map from the mapper).
    pub fn checkpoint(&self) -> TrackingCheckpoint {
        TrackingCheckpoint {
            state: self.state,
            requests: self.requests.clone(),
            last: self.tracker.last_frame().cloned(),
            motion: self.tracker.motion().clone(),
            reference: self.tracker.reference(),
            frames_since_keyframe: self.frames_since_keyframe,
            sightings: self.sightings.clone(),
            manhattan: self.manhattan.clone(),
            map_from_odom: self.map_from_odom,
            saved: self.saved,
        }
    }

    /// Resumes from a checkpoint and the map it tracked against
    /// (`checkpoint.requests.map_seq()`; `None`: no map was published, so tracking
    /// starts a new map where the checkpoint left off).
    pub fn restore(&mut self, checkpoint: TrackingCheckpoint, map: Option<MapUpdate>) {
        self.requests
            .resume(&checkpoint.requests, map.as_ref().map(|m| m.seq));
        self.frames_since_keyframe = checkpoint.frames_since_keyframe;
        self.manhattan = checkpoint.manhattan;
        self.sightings = checkpoint.sightings;
        self.state = checkpoint.state;
        self.map_from_odom = checkpoint.map_from_odom;
        self.saved = checkpoint.saved;
        match map {
            Some(update) => {
                self.map = update.map;
                self.map.canonicalise();
                if let TrackingState::NoMap { reset: true } = self.state {
                    self.map.clear_keyframes();
                }
            }
            None if self.state != (TrackingState::NoMap { reset: true }) => {
                self.state = TrackingState::NoMap { reset: false };
            }
            None => {}
        }
        if let Some(reference) = checkpoint.reference {
            self.tracker.set_reference(reference);
        }
        if let Some(last) = checkpoint.last {
            self.tracker.restore(checkpoint.motion, last);
        }
    }
}
