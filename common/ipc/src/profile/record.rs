//! The per-frame records of a profile and how headers are merged into them.

use serde::{Deserialize, Serialize};

use crate::header::{MsgHeader, Stage, StageStamp};

/// The stamps of the stages one frame passed, by stage name; a stage that did not
/// handle the frame is absent (serialised in pipeline order, empty stamps omitted).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StageTimes {
    /// Frame input.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<StageStamp>,
    /// ORB point extraction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points: Option<StageStamp>,
    /// Line extraction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lines: Option<StageStamp>,
    /// Planes and Manhattan axes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planes: Option<StageStamp>,
    /// Pose tracking.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracker: Option<StageStamp>,
    /// Local mapping (keyframes only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mapper: Option<StageStamp>,
    /// Loop closing (keyframes only, on the map the mapper sent it).
    #[serde(rename = "loop", skip_serializing_if = "Option::is_none")]
    pub loop_closing: Option<StageStamp>,
}

impl StageTimes {
    /// The stamps of `stage`, if it handled the frame.
    pub fn get(&self, stage: Stage) -> Option<StageStamp> {
        *self.slot(stage)
    }

    fn slot(&self, stage: Stage) -> &Option<StageStamp> {
        match stage {
            Stage::Source => &self.source,
            Stage::Points => &self.points,
            Stage::Lines => &self.lines,
            Stage::Planes => &self.planes,
            Stage::Tracker => &self.tracker,
            Stage::Mapper => &self.mapper,
            Stage::Loop => &self.loop_closing,
        }
    }

    fn slot_mut(&mut self, stage: Stage) -> &mut Option<StageStamp> {
        match stage {
            Stage::Source => &mut self.source,
            Stage::Points => &mut self.points,
            Stage::Lines => &mut self.lines,
            Stage::Planes => &mut self.planes,
            Stage::Tracker => &mut self.tracker,
            Stage::Mapper => &mut self.mapper,
            Stage::Loop => &mut self.loop_closing,
        }
    }

    /// Stores `stamp` for `stage` unless the stage already has one or `stamp` is empty
    /// (the first stamp of a stage wins, as in [`MsgHeader::merge_stamps`]).
    fn fill(&mut self, stage: Stage, stamp: StageStamp) {
        let slot = self.slot_mut(stage);
        if slot.is_none() && !stamp.is_empty() {
            *slot = Some(stamp);
        }
    }

    /// Source "started" to tracker "finished" (frame published to pose out), in ns, when
    /// both exist (the definition of [`MsgHeader::end_to_end_ns`]).
    pub fn end_to_end_ns(&self) -> Option<u64> {
        let start = self.source?.started_ns;
        let pose = self.tracker?.finished_ns;
        (start != 0 && pose != 0)
            .then(|| pose.checked_sub(start))
            .flatten()
    }
}

/// What the profile knows about one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Input frame index.
    pub frame_id: u64,
    /// Capture timestamp in seconds (dataset / sensor clock).
    pub capture_time_s: f64,
    /// Tracking status the tracker reported ("ok", "lost", ...); empty when only a
    /// mapper stamp reached the recorder.
    #[serde(default)]
    pub status: String,
    /// Per-stage stamps.
    #[serde(default)]
    pub stages: StageTimes,
    /// End-to-end latency in ns ([`StageTimes::end_to_end_ns`]), kept up to date as
    /// stamps are merged in.
    #[serde(default)]
    pub end_to_end_ns: Option<u64>,
}

impl FrameRecord {
    fn empty(header: &MsgHeader) -> Self {
        Self {
            frame_id: header.frame_id,
            capture_time_s: header.capture_stamp().secs(),
            status: String::new(),
            stages: StageTimes::default(),
            end_to_end_ns: None,
        }
    }

    /// Processing time (started -> finished) of `stage` in milliseconds, if stamped.
    pub fn processing_ms(&self, stage: Stage) -> Option<f64> {
        Some(ns_to_ms(self.stages.get(stage)?.processing_ns()?))
    }

    /// Queueing time (received -> started) of `stage` in milliseconds, if stamped.
    pub fn queueing_ms(&self, stage: Stage) -> Option<f64> {
        Some(ns_to_ms(self.stages.get(stage)?.queueing_ns()?))
    }
}

/// Nanoseconds as milliseconds.
pub(super) fn ns_to_ms(ns: u64) -> f64 {
    ns as f64 / 1e6
}

/// The stage timings of one run, one record per frame in frame order, as the
/// supervisor's recorder collects them from message headers.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    /// Pipeline mode of the run ("lockstep", "realtime", "threads", "inline").
    pub mode: String,
    /// Frame records sorted by frame id, one per id.
    pub frames: Vec<FrameRecord>,
}

impl Profile {
    /// An empty profile of a run in `mode`.
    pub fn new(mode: &str) -> Self {
        Self {
            mode: mode.to_string(),
            frames: Vec::new(),
        }
    }

    /// Records the header of a pose message (every stage stamp it carries) with the
    /// tracking `status`. A frame already recorded keeps its stamps and gets the ones it
    /// lacked, and keeps a non-empty status.
    pub fn record(&mut self, header: &MsgHeader, status: &str) {
        let frame = self.frame_mut(header);
        for stage in Stage::ALL {
            frame.stages.fill(stage, header.stamp(stage));
        }
        if frame.status.is_empty() {
            frame.status = status.to_string();
        }
        frame.end_to_end_ns = frame.stages.end_to_end_ns();
    }

    /// Records only `stage`'s stamp from `header` (e.g. the mapper's stamp on a
    /// local-map snapshot, carrying the keyframe's frame id), creating the frame's record
    /// when it is not there yet.
    pub fn record_stage(&mut self, header: &MsgHeader, stage: Stage) {
        let frame = self.frame_mut(header);
        frame.stages.fill(stage, header.stamp(stage));
        frame.end_to_end_ns = frame.stages.end_to_end_ns();
    }

    /// The record of `frame_id`, if any.
    pub fn frame(&self, frame_id: u64) -> Option<&FrameRecord> {
        let i = self
            .frames
            .binary_search_by_key(&frame_id, |f| f.frame_id)
            .ok()?;
        self.frames.get(i)
    }

    /// The stages that stamped at least one frame, in pipeline order.
    pub fn stages_present(&self) -> Vec<Stage> {
        Stage::ALL
            .into_iter()
            .filter(|&s| self.frames.iter().any(|f| f.stages.get(s).is_some()))
            .collect()
    }

    /// The record of the header's frame, inserted in frame order when new. Frames
    /// arrive almost in order, so the common case is a push at the end.
    fn frame_mut(&mut self, header: &MsgHeader) -> &mut FrameRecord {
        let id = header.frame_id;
        let at = match self.frames.last() {
            Some(last) if last.frame_id < id => Err(self.frames.len()),
            None => Err(0),
            Some(_) => self.frames.binary_search_by_key(&id, |f| f.frame_id),
        };
        let i = match at {
            Ok(i) => i,
            Err(i) => {
                self.frames.insert(i, FrameRecord::empty(header));
                i
            }
        };
        &mut self.frames[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::ids::FrameId;
    use gfs_core::stamp::Stamp;

    fn stamp(received_ns: u64, started_ns: u64, finished_ns: u64) -> StageStamp {
        StageStamp {
            received_ns,
            started_ns,
            finished_ns,
        }
    }

    #[test]
    fn records_are_sorted_and_merged_by_frame_id() {
        let mut profile = Profile::new("realtime");
        for id in [3, 1, 2] {
            let mut h = MsgHeader::new(FrameId(id), Stamp::from_nanos(id as i64 * 100_000_000));
            *h.stamp_mut(Stage::Source) = stamp(100, 110, 200);
            *h.stamp_mut(Stage::Tracker) = stamp(300, 310, 1_000);
            profile.record(&h, "ok");
        }
        let ids: Vec<u64> = profile.frames.iter().map(|f| f.frame_id).collect();
        assert_eq!(ids, [1, 2, 3]);
        assert_eq!(profile.frame(2).unwrap().end_to_end_ns, Some(890));

        // The mapper's snapshot for keyframe 2 adds its stamp; the pose was out before the
        // mapping, so end-to-end stays frame published -> pose out.
        let mut m = MsgHeader::new(FrameId(2), Stamp::from_nanos(200_000_000));
        *m.stamp_mut(Stage::Mapper) = stamp(1_100, 1_200, 5_110);
        // A stray stamp of another stage on that header is not taken.
        *m.stamp_mut(Stage::Points) = stamp(1, 2, 3);
        profile.record_stage(&m, Stage::Mapper);
        let f2 = profile.frame(2).unwrap();
        assert_eq!(f2.stages.mapper, Some(stamp(1_100, 1_200, 5_110)));
        assert_eq!(f2.stages.points, None);
        assert_eq!(f2.end_to_end_ns, Some(890));
        assert_eq!(f2.processing_ms(Stage::Mapper), Some(0.00391));

        // A later header for frame 3 fills missing stamps, keeps present ones and the status.
        let mut late = MsgHeader::new(FrameId(3), Stamp::from_nanos(300_000_000));
        *late.stamp_mut(Stage::Source) = stamp(7, 8, 9);
        *late.stamp_mut(Stage::Lines) = stamp(120, 130, 400);
        profile.record(&late, "lost");
        let f3 = profile.frame(3).unwrap();
        assert_eq!(f3.stages.source, Some(stamp(100, 110, 200)));
        assert_eq!(f3.stages.lines, Some(stamp(120, 130, 400)));
        assert_eq!(f3.status, "ok");
        assert_eq!(profile.frames.len(), 3);

        // A mapper stamp for a frame never seen creates a record without status.
        let mut m9 = MsgHeader::new(FrameId(9), Stamp::from_nanos(900_000_000));
        *m9.stamp_mut(Stage::Mapper) = stamp(1, 2, 4);
        profile.record_stage(&m9, Stage::Mapper);
        let f9 = profile.frame(9).unwrap();
        assert_eq!((f9.status.as_str(), f9.end_to_end_ns), ("", None));
        assert_eq!(
            profile.stages_present(),
            [Stage::Source, Stage::Lines, Stage::Tracker, Stage::Mapper]
        );
    }
}
