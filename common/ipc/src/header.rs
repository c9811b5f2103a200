//! The header every pipeline message carries: frame id, capture time and the monotonic
//! stamps of the stages the data passed, so the profile travels with the data
//! (DESIGN.md "Messages").
//!
//! It is the iceoryx2 *user header* of every topic (`Sample::user_header()`), so it sits
//! beside the payload in shared memory and is read without touching the payload.

use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use iceoryx2::prelude::ZeroCopySend;

use crate::clock::monotonic_ns;

/// A pipeline stage, the index of its slot in [`MsgHeader::stamps`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Stage {
    /// Frame input: decode, undistort, gray, depth in metres.
    Source = 0,
    /// ORB point extraction.
    Points = 1,
    /// Line extraction, homogenisation, 3D lines.
    Lines = 2,
    /// Plane normals and Manhattan axes.
    Planes = 3,
    /// Pose tracking.
    Tracker = 4,
    /// Local mapping.
    Mapper = 5,
    /// Loop closing: detection, verification, pose graph.
    Loop = 6,
}

impl Stage {
    /// Number of stages (length of the stamp array).
    pub const COUNT: usize = 7;

    /// All stages in pipeline order.
    pub const ALL: [Stage; Stage::COUNT] = [
        Stage::Source,
        Stage::Points,
        Stage::Lines,
        Stage::Planes,
        Stage::Tracker,
        Stage::Mapper,
        Stage::Loop,
    ];

    /// Slot of this stage in [`MsgHeader::stamps`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name, as used for service executables, node names and profile keys.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Source => "source",
            Stage::Points => "points",
            Stage::Lines => "lines",
            Stage::Planes => "planes",
            Stage::Tracker => "tracker",
            Stage::Mapper => "mapper",
            Stage::Loop => "loop",
        }
    }

    /// The stage called `name` (see [`Stage::name`]), if any.
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// When one stage handled the message, in CLOCK_MONOTONIC nanoseconds
/// ([`crate::monotonic_ns`]); 0 = not stamped. Serde form (in a [`crate::profile`]):
/// `{"received_ns": .., "started_ns": .., "finished_ns": ..}`.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend, serde::Serialize, serde::Deserialize,
)]
#[type_name("gfsvo::StageStamp")]
#[repr(C)]
pub struct StageStamp {
    /// The stage took the input message out of its queue.
    pub received_ns: u64,
    /// The stage started processing the frame.
    pub started_ns: u64,
    /// The stage finished and is about to publish.
    pub finished_ns: u64,
}

impl StageStamp {
    /// True when no time was recorded.
    pub fn is_empty(&self) -> bool {
        self.received_ns == 0 && self.started_ns == 0 && self.finished_ns == 0
    }

    /// Processing time `finished - started` in ns, when both are stamped and ordered.
    pub fn processing_ns(&self) -> Option<u64> {
        span(self.started_ns, self.finished_ns)
    }

    /// Queueing time inside the stage `started - received` in ns, when both are stamped.
    pub fn queueing_ns(&self) -> Option<u64> {
        span(self.received_ns, self.started_ns)
    }
}

fn span(from: u64, to: u64) -> Option<u64> {
    (from != 0 && to != 0)
        .then(|| to.checked_sub(from))
        .flatten()
}

/// The header of every message: which frame, when it was captured, and when each stage
/// handled it. Fixed layout (`#[repr(C)]`, 184 bytes) shared by all processes.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::MsgHeader")]
#[repr(C)]
pub struct MsgHeader {
    /// Input frame index ([`FrameId`] value).
    pub frame_id: u64,
    /// Capture stamp of the frame (dataset / sensor clock), integer nanoseconds since
    /// the epoch ([`Stamp::nanos`]): exact, as the source gave it.
    pub capture_stamp_ns: i64,
    /// Stamps indexed by [`Stage::index`].
    pub stamps: [StageStamp; Stage::COUNT],
}

impl MsgHeader {
    /// A header for frame `frame_id` captured at `capture`, with no stage stamp.
    pub fn new(frame_id: FrameId, capture: Stamp) -> Self {
        Self {
            frame_id: frame_id.0,
            capture_stamp_ns: capture.nanos(),
            stamps: [StageStamp::default(); Stage::COUNT],
        }
    }

    /// The capture stamp.
    pub fn capture_stamp(&self) -> Stamp {
        Stamp::from_nanos(self.capture_stamp_ns)
    }

    /// The frame id as its typed id.
    pub fn frame(&self) -> FrameId {
        FrameId(self.frame_id)
    }

    /// The stamps of `stage`.
    pub fn stamp(&self, stage: Stage) -> StageStamp {
        self.stamps[stage.index()]
    }

    /// Mutable stamps of `stage`.
    pub fn stamp_mut(&mut self, stage: Stage) -> &mut StageStamp {
        &mut self.stamps[stage.index()]
    }

    /// Records "received" for `stage` at the current monotonic time.
    pub fn mark_received(&mut self, stage: Stage) {
        self.stamp_mut(stage).received_ns = monotonic_ns();
    }

    /// Records "started" for `stage` at the current monotonic time.
    pub fn mark_started(&mut self, stage: Stage) {
        self.stamp_mut(stage).started_ns = monotonic_ns();
    }

    /// Records "finished" for `stage` at the current monotonic time.
    pub fn mark_finished(&mut self, stage: Stage) {
        self.stamp_mut(stage).finished_ns = monotonic_ns();
    }

    /// Copies the stamps `other` has and `self` lacks: the tracker joins the point, line
    /// and plane messages of one frame into one header carrying every stage's stamps.
    /// Stamps already present in `self` win.
    pub fn merge_stamps(&mut self, other: &MsgHeader) {
        for (mine, theirs) in self.stamps.iter_mut().zip(other.stamps.iter()) {
            if mine.is_empty() {
                *mine = *theirs;
            }
        }
    }

    /// End-to-end latency in ns: the source's "started" stamp (the frame is published)
    /// to the tracker's "finished" stamp (its pose is out), when both exist. A keyframe's
    /// local mapping comes after its pose and is the mapper's own processing time.
    pub fn end_to_end_ns(&self) -> Option<u64> {
        span(
            self.stamp(Stage::Source).started_ns,
            self.stamp(Stage::Tracker).finished_ns,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_fixed() {
        assert_eq!(std::mem::size_of::<StageStamp>(), 24);
        assert_eq!(std::mem::size_of::<MsgHeader>(), 8 + 8 + 7 * 24);
        assert_eq!(std::mem::align_of::<MsgHeader>(), 8);
    }

    #[test]
    fn stage_names_round_trip() {
        for s in Stage::ALL {
            assert_eq!(Stage::from_name(s.name()), Some(s));
        }
        assert_eq!(Stage::from_name("recorder"), None);
        assert_eq!(Stage::Mapper.index(), 5);
    }

    #[test]
    fn merge_keeps_own_stamps_and_fills_missing() {
        let mut a = MsgHeader::new(FrameId(7), Stamp::from_nanos(1_500_000_000));
        a.stamp_mut(Stage::Source).finished_ns = 10;
        a.stamp_mut(Stage::Points).finished_ns = 20;
        let mut b = MsgHeader::new(FrameId(7), Stamp::from_nanos(1_500_000_000));
        b.stamp_mut(Stage::Points).finished_ns = 99;
        b.stamp_mut(Stage::Lines).finished_ns = 30;
        a.merge_stamps(&b);
        assert_eq!(a.stamp(Stage::Points).finished_ns, 20);
        assert_eq!(a.stamp(Stage::Lines).finished_ns, 30);
        assert!(a.stamp(Stage::Planes).is_empty());
    }

    #[test]
    fn spans_need_both_stamps() {
        let mut h = MsgHeader::new(FrameId(1), Stamp::default());
        assert_eq!(h.end_to_end_ns(), None);
        *h.stamp_mut(Stage::Source) = StageStamp {
            received_ns: 100,
            started_ns: 150,
            finished_ns: 400,
        };
        h.stamp_mut(Stage::Mapper).finished_ns = 30_000;
        assert_eq!(h.end_to_end_ns(), None, "no pose yet");
        h.stamp_mut(Stage::Tracker).finished_ns = 1_000;
        assert_eq!(h.stamp(Stage::Source).queueing_ns(), Some(50));
        assert_eq!(h.stamp(Stage::Source).processing_ns(), Some(250));
        assert_eq!(h.stamp(Stage::Tracker).processing_ns(), None);
        assert_eq!(
            h.end_to_end_ns(),
            Some(850),
            "the mapping after the pose is not counted"
        );
    }
}
