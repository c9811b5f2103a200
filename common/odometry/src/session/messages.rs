//! What the tracking half and the mapping half of the odometry tell each other: a
//! keyframe request (or, when lost, a relocalisation request) one way, the map after
//! local mapping the other way. Both are plain
//! serde values; the pipeline sends them as bincode, the in-process odometry by value.

use crate::frontend::features::FrameFeatures;
use crate::loop_closing::LoopCorrection;
use crate::map::Map;
use crate::map::manhattan::WorldManhattan;
use crate::tracking::sightings::Sightings;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::{FrameId, KeyFrameId, MapPointId};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// The tracker asks the mapper to make a frame a keyframe.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct KeyFrameRequest {
    /// Request number, counting from 1; the mapper applies each number once, so a
    /// request sent again after a restart is harmless.
    pub seq: u64,
    /// The tracked frame with its landmark links.
    pub frame: TrackedFrame,
    /// The tracker's world Manhattan axes (it refines them on every tracked frame).
    pub manhattan: WorldManhattan,
    /// Drop every keyframe first: tracking was lost and a new local map starts here.
    pub reset: bool,
    /// The landmark sightings since the last request (the mapper culls on them).
    pub sightings: Sightings,
    /// The loop corrections of the map the frame was tracked against (`None` for a
    /// frame that starts a map).
    pub tracked_against: Option<TrackedAgainst>,
}

/// The loop corrections a tracked frame's pose reflects: in realtime the mapper may have
/// applied another correction since, and then moves the frame as its reference keyframe
/// was moved ([`crate::map::Map::keyframe_correction`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackedAgainst {
    /// [`Map::corrections`] of the tracker's map.
    pub corrections: u64,
    /// The frame's reference keyframe.
    pub reference: KeyFrameId,
    /// The loop correction of the reference keyframe in the tracker's map.
    pub reference_correction: Isometry3<f64>,
}

/// The mapper's answer to a request: the tracker's neighbourhood of the map after local
/// mapping ([`crate::session::MappingSession::update_around`]); with the whole map, the
/// mapper's checkpoint and the loop stage's message
/// ([`crate::session::MappingSession::checkpoint`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MapUpdate {
    /// The request this answers.
    pub seq: u64,
    /// The keyframe made from the request's frame (`None` when the request was a
    /// duplicate of one already applied).
    pub keyframe: Option<KeyFrameId>,
    /// The map: the tracker's neighbourhood, or the whole map.
    pub map: Map,
    /// The world Manhattan axes after mapping.
    pub manhattan: WorldManhattan,
    /// The mapper's recently created points still on probation: part of the mapper's
    /// checkpoint, empty in the tracker's neighbourhood.
    pub recent_points: Vec<MapPointId>,
    /// The lost frame found in the map, when this answers a [`RelocalisationRequest`]
    /// that succeeded.
    pub relocalised: Option<Relocalised>,
}

/// The tracker, lost and not relocalised in its own map, asks the mapper to find a
/// frame in the whole map. Numbered with the keyframe requests ([`KeyFrameRequest::
/// seq`]): the mapper applies each number once and answers with a [`MapUpdate`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RelocalisationRequest {
    /// Request number, shared with the keyframe requests.
    pub seq: u64,
    /// The lost frame's features.
    pub features: FrameFeatures,
}

/// What the tracking half sends the mapping half (the pipeline's `keyframe` topic).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[expect(
    clippy::large_enum_variant,
    reason = "one request per keyframe or lost frame, decoded and taken apart at once"
)]
pub enum MapRequest {
    /// Make a frame a keyframe.
    KeyFrame(KeyFrameRequest),
    /// Find a lost frame in the whole map.
    Relocalise(RelocalisationRequest),
}

impl MapRequest {
    /// The request number.
    pub fn seq(&self) -> u64 {
        match self {
            Self::KeyFrame(r) => r.seq,
            Self::Relocalise(r) => r.seq,
        }
    }
}

/// A lost frame found in the mapper's map: the tracker goes on from its pose, with the
/// keyframe it was found against as the reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Relocalised {
    /// The frame of the request.
    pub frame: FrameId,
    /// Its capture stamp.
    pub timestamp: gfs_core::stamp::Stamp,
    /// The keyframe whose place it sees.
    pub keyframe: KeyFrameId,
    /// Its `camera_from_world` in the map.
    pub camera_from_world: Isometry3<f64>,
    /// The map point of each of its keypoints (inliers only).
    pub point_ids: Vec<Option<MapPointId>>,
    /// Point inliers of the pose optimisation.
    pub inliers: usize,
}

/// The loop stage's answer to the map of one keyframe request: the correction of the
/// loop it closed there, if any. Every keyframe gets one, so that a lockstep mapper can
/// wait for it and stay reproducible.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoopVerdict {
    /// The request whose map was searched ([`MapUpdate::seq`]).
    pub seq: u64,
    /// The loop closed at its keyframe.
    pub correction: Option<LoopCorrection>,
}

/// [`MapUpdate`] borrowed from the mapper, to encode without copying the map.
#[derive(Debug, Serialize)]
pub struct MapUpdateRef<'a> {
    /// See [`MapUpdate::seq`].
    pub seq: u64,
    /// See [`MapUpdate::keyframe`].
    pub keyframe: Option<KeyFrameId>,
    /// See [`MapUpdate::map`].
    pub map: &'a Map,
    /// See [`MapUpdate::manhattan`].
    pub manhattan: &'a WorldManhattan,
    /// See [`MapUpdate::recent_points`].
    pub recent_points: &'a [MapPointId],
    /// See [`MapUpdate::relocalised`].
    pub relocalised: Option<&'a Relocalised>,
}

impl MapUpdate {
    /// The map as a viewer draws it, with the world Manhattan axes when all three are
    /// known.
    pub fn scene(&self) -> gfs_core::scene::Scene {
        let mut scene = self.map.scene();
        if let [Some(a), Some(b), Some(c)] = [0, 1, 2].map(|k| self.manhattan.axis(k)) {
            scene.axes = Some([a, b, c]);
        }
        scene
    }
}

impl MapUpdateRef<'_> {
    /// An owned copy.
    pub fn to_owned(&self) -> MapUpdate {
        MapUpdate {
            seq: self.seq,
            keyframe: self.keyframe,
            map: self.map.clone(),
            manhattan: self.manhattan.clone(),
            recent_points: self.recent_points.to_vec(),
            relocalised: self.relocalised.cloned(),
        }
    }
}
