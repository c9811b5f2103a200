//! The tracking half's state machine and its bookkeeping of keyframe requests; both
//! are saved as they are in the tracker's checkpoint.

use gfs_core::ids::FrameId;
use serde::{Deserialize, Serialize};

/// Where tracking stands.
///
/// ```text
///  NoMap ──(frame with enough depth: first keyframe)──► Tracking
///  Tracking ──(frame not tracked nor relocalised)──► Lost { frames: 1 }
///  Lost { frames: n } ──(tracked or relocalised, by the tracker or, answering a
///                        relocalisation request, by the mapping half)──► Tracking
///  Lost { frames: n } ──(n + 1 = frames_before_new_map)──► NoMap { reset: true }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TrackingState {
    /// No map to track against: the next frame with enough keypoints with depth starts
    /// one, at the predicted pose. With `reset`, a lost map was abandoned and the
    /// mapping half drops its keyframes with the first request.
    NoMap {
        /// The mapping half still holds the abandoned map.
        reset: bool,
    },
    /// Tracking against the map.
    Tracking,
    /// The last `frames` frames were neither tracked nor relocalised.
    Lost {
        /// Consecutive lost frames.
        frames: u32,
    },
}

impl Default for TrackingState {
    fn default() -> Self {
        Self::NoMap { reset: false }
    }
}

/// Numbers the keyframe requests and tells which maps answer them. Each request gets
/// the next number; the mapping half applies each number once, so a request sent
/// again is harmless, and each map it sends carries the number it answers.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RequestLedger {
    last_sent: u64,
    map_seq: u64,
    /// Not in a checkpoint: a restarted tracker re-tracks the frame after its
    /// checkpoint and makes the request again, with the same number.
    #[serde(skip)]
    pending: Option<(u64, FrameId)>,
}

/// What a map from the mapping half is to the tracking half.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapReceipt {
    /// It answers the pending request.
    Answer,
    /// A newer map that answers no pending request (one sent before a restart).
    Newer,
    /// Older than the map held, or answering a request not made yet: ignored.
    Ignored,
}

impl RequestLedger {
    /// The number of a new request for `frame`, which is now pending.
    pub fn open(&mut self, frame: FrameId) -> u64 {
        self.last_sent += 1;
        self.pending = Some((self.last_sent, frame));
        self.last_sent
    }

    /// The request waiting for its map (number and frame), if any.
    pub fn pending(&self) -> Option<(u64, FrameId)> {
        self.pending
    }

    /// The request the map held answers (0 before the first map).
    pub fn map_seq(&self) -> u64 {
        self.map_seq
    }

    /// The last request number used.
    pub fn last_sent(&self) -> u64 {
        self.last_sent
    }

    /// Takes in the number of a map received: a map older than the one held, or newer
    /// than the requests made, is ignored (a restarted tracker receives the last few
    /// maps again, and a map answering a request it has not made yet is taken when it
    /// makes it).
    pub fn receive(&mut self, seq: u64) -> MapReceipt {
        let answers = self.pending.is_some_and(|(pending, _)| pending == seq);
        let stale = seq < self.map_seq || (seq == self.map_seq && !answers);
        if stale || seq > self.last_sent {
            return MapReceipt::Ignored;
        }
        self.map_seq = seq;
        if answers {
            self.pending = None;
            MapReceipt::Answer
        } else {
            MapReceipt::Newer
        }
    }

    /// Resumes the numbering of a checkpoint, holding the map that answered `map_seq`.
    pub fn resume(&mut self, saved: &RequestLedger, map_seq: Option<u64>) {
        self.last_sent = saved.last_sent;
        self.pending = None;
        if let Some(seq) = map_seq {
            self.map_seq = seq;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_numbered_and_their_answer_clears_the_pending_one() {
        let mut ledger = RequestLedger::default();
        assert_eq!(ledger.open(FrameId(3)), 1);
        assert_eq!(ledger.pending(), Some((1, FrameId(3))));
        assert_eq!(ledger.receive(1), MapReceipt::Answer);
        assert_eq!((ledger.pending(), ledger.map_seq()), (None, 1));
        // The same map again (a restarted mapper resends it): nothing new.
        assert_eq!(ledger.receive(1), MapReceipt::Ignored);
    }

    #[test]
    fn old_maps_and_answers_to_requests_not_made_are_ignored() {
        let mut ledger = RequestLedger::default();
        ledger.open(FrameId(0));
        ledger.receive(1);
        ledger.open(FrameId(5));
        assert_eq!(ledger.receive(3), MapReceipt::Ignored, "request 3 not made");
        assert_eq!(
            ledger.receive(0),
            MapReceipt::Ignored,
            "older than the map held"
        );
        assert_eq!(ledger.pending(), Some((2, FrameId(5))));
        assert_eq!(ledger.receive(2), MapReceipt::Answer);
    }

    #[test]
    fn a_newer_map_that_answers_nothing_pending_is_taken() {
        let mut ledger = RequestLedger::default();
        ledger.open(FrameId(0));
        ledger.open(FrameId(4));
        // Request 1's answer arrives after request 2 was made.
        assert_eq!(ledger.receive(1), MapReceipt::Newer);
        assert_eq!(ledger.pending(), Some((2, FrameId(4))));
        assert_eq!(ledger.receive(2), MapReceipt::Answer);
    }

    #[test]
    fn a_resumed_ledger_numbers_on_and_waits_for_nothing() {
        let roundtrip = |ledger: &RequestLedger| {
            let config = bincode::config::standard();
            let bytes = bincode::serde::encode_to_vec(ledger, config).expect("encode");
            let (decoded, _): (RequestLedger, usize) =
                bincode::serde::decode_from_slice(&bytes, config).expect("decode");
            decoded
        };
        // Killed while waiting for request 2 (lockstep): the checkpoint is the one of
        // the frame before, so frame 7 is tracked again and asks with the same number.
        let mut saved = RequestLedger::default();
        saved.open(FrameId(0));
        saved.receive(1);
        let mut resumed = RequestLedger::default();
        resumed.resume(&roundtrip(&saved), Some(1));
        assert_eq!((resumed.last_sent(), resumed.map_seq()), (1, 1));
        assert_eq!(resumed.open(FrameId(7)), 2);
        // Killed after the checkpoint of frame 7 with request 2 unanswered (realtime):
        // nothing is pending after the restart, and the answer is taken as a newer map.
        saved.open(FrameId(7));
        let decoded = roundtrip(&saved);
        assert_eq!(decoded.pending(), None, "pending is not saved");
        let mut resumed = RequestLedger::default();
        resumed.resume(&decoded, Some(1));
        assert_eq!(resumed.receive(2), MapReceipt::Newer);
    }
}
