//! The tracker's join of the feature messages of a frame (points, lines, Manhattan axes,
//! and the planes and depth grid when the tracker uses them) by frame id, with a
//! deadline for a message that does not come.

use crate::wire::{WireKeyPoint, WireLine, WireManhattan};
use gfs_core::ids::FrameId;
use gfs_ipc::MsgHeader;
use gfs_odometry::{FrameFeatures, FrameSurfaces};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// What arrived for one frame so far.
struct Pending {
    header: MsgHeader,
    first_seen: Instant,
    features: FrameFeatures,
    points: bool,
    lines: bool,
    manhattan: bool,
    surfaces: bool,
}

impl Pending {
    fn complete(&self, surfaces_expected: bool) -> bool {
        self.points && self.lines && self.manhattan && (self.surfaces || !surfaces_expected)
    }
}

/// A frame ready for tracking.
pub struct Joined {
    /// The header with the stamps of every stage the parts passed.
    pub header: MsgHeader,
    /// The features (empty where a part is missing).
    pub features: FrameFeatures,
    /// True when a part did not arrive before the deadline.
    pub incomplete: bool,
}

/// The three feature messages of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// From the points stage.
    Points,
    /// From the lines stage.
    Lines,
    /// From the planes stage.
    Manhattan,
    /// From the planes stage, when the tracker uses planes or depth.
    Surfaces,
}

/// Frames waiting for their parts, by id.
#[derive(Default)]
pub struct FrameJoin {
    pending: BTreeMap<u64, Pending>,
    surfaces_expected: bool,
}

impl FrameJoin {
    /// A join that waits for the surfaces part of each frame too when
    /// `surfaces_expected`.
    pub fn new(surfaces_expected: bool) -> Self {
        Self {
            surfaces_expected,
            ..Self::default()
        }
    }

    fn entry(&mut self, header: &MsgHeader) -> &mut Pending {
        let pending = self
            .pending
            .entry(header.frame_id)
            .or_insert_with(|| Pending {
                header: *header,
                first_seen: Instant::now(),
                features: FrameFeatures {
                    id: FrameId(header.frame_id),
                    timestamp: header.capture_stamp(),
                    ..FrameFeatures::default()
                },
                points: false,
                lines: false,
                manhattan: false,
                surfaces: false,
            });
        pending.header.merge_stamps(header);
        pending
    }

    /// Adds the points of a frame (a second copy of the same part is ignored).
    pub fn add_points(&mut self, header: &MsgHeader, points: &[WireKeyPoint]) {
        let p = self.entry(header);
        if !std::mem::replace(&mut p.points, true) {
            p.features.keypoints = points.iter().map(WireKeyPoint::keypoint).collect();
            p.features.point_descriptors = points.iter().map(|k| k.descriptor).collect();
        }
    }

    /// Adds the lines of a frame.
    pub fn add_lines(&mut self, header: &MsgHeader, lines: &[WireLine]) {
        let p = self.entry(header);
        if !std::mem::replace(&mut p.lines, true) {
            p.features.lines = lines.iter().map(WireLine::line).collect();
            p.features.line_descriptors = lines.iter().map(|l| l.descriptor).collect();
            p.features.lines3d = lines.iter().map(WireLine::line3).collect();
        }
    }

    /// Adds the Manhattan axes of a frame (an empty slice: none found).
    pub fn add_manhattan(&mut self, header: &MsgHeader, axes: &[WireManhattan]) {
        let p = self.entry(header);
        if !std::mem::replace(&mut p.manhattan, true) {
            p.features.manhattan = axes.first().and_then(WireManhattan::axes);
        }
    }

    /// Adds the planes and depth grid of a frame (a message that does not decode counts
    /// as none).
    pub fn add_surfaces(&mut self, header: &MsgHeader, surfaces: FrameSurfaces) {
        let p = self.entry(header);
        if !std::mem::replace(&mut p.surfaces, true) {
            p.features.planes = surfaces.planes;
            p.features.depth = surfaces.depth;
        }
    }

    /// The part to wait for: one the oldest pending frame still lacks (the tracker needs
    /// them all, so sleeping on the topic of any missing one wakes it no later than the
    /// frame can be complete); points, the slowest stage, when nothing is pending.
    pub fn waiting_for(&self) -> Part {
        match self.pending.first_key_value() {
            Some((_, p)) if !p.points => Part::Points,
            Some((_, p)) if !p.manhattan => Part::Manhattan,
            Some((_, p)) if !p.lines => Part::Lines,
            Some((_, p)) if self.surfaces_expected && !p.surfaces => Part::Surfaces,
            _ => Part::Points,
        }
    }

    /// Forgets every frame before `id` (already tracked, or skipped in realtime).
    pub fn drop_before(&mut self, id: u64) {
        self.pending = self.pending.split_off(&id);
    }

    /// Lockstep: the oldest frame once all its parts are in, or once `deadline` passed
    /// since its first part arrived (tracked without the missing ones).
    pub fn next_in_order(&mut self, deadline: Duration) -> Option<Joined> {
        let (&id, p) = self.pending.first_key_value()?;
        if !p.complete(self.surfaces_expected) && p.first_seen.elapsed() < deadline {
            return None;
        }
        self.take(id)
    }

    /// Realtime: the newest complete frame, dropping older ones; or the oldest whose
    /// deadline passed.
    pub fn next_newest(&mut self, deadline: Duration) -> Option<Joined> {
        let newest_complete = self
            .pending
            .iter()
            .rev()
            .find(|(_, p)| p.complete(self.surfaces_expected))
            .map(|(id, _)| *id);
        if let Some(id) = newest_complete {
            self.drop_before(id);
            return self.take(id);
        }
        let (&id, p) = self.pending.first_key_value()?;
        (p.first_seen.elapsed() >= deadline)
            .then(|| self.take(id))
            .flatten()
    }

    fn take(&mut self, id: u64) -> Option<Joined> {
        let p = self.pending.remove(&id)?;
        let incomplete = !p.complete(self.surfaces_expected);
        if incomplete {
            tracing::warn!(
                frame = id,
                points = p.points,
                lines = p.lines,
                manhattan = p.manhattan,
                surfaces = p.surfaces,
                "tracker: feature message missing at the deadline; tracking without it"
            );
        }
        Some(Joined {
            header: p.header,
            features: p.features,
            incomplete,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::stamp::Stamp;

    fn header(id: u64) -> MsgHeader {
        MsgHeader::new(FrameId(id), Stamp::from_nanos(id as i64 * 100_000_000))
    }

    #[test]
    fn frames_are_released_complete_in_order_or_at_the_deadline() {
        let mut join = FrameJoin::default();
        let long = Duration::from_secs(60);
        join.add_points(&header(1), &[WireKeyPoint::default(); 3]);
        join.add_lines(&header(1), &[WireLine::default(); 2]);
        assert!(join.next_in_order(long).is_none(), "axes missing");
        join.add_manhattan(&header(1), &[]);
        join.add_points(&header(2), &[]);
        let j = join.next_in_order(long).unwrap();
        assert_eq!((j.features.id, j.features.keypoints.len()), (FrameId(1), 3));
        assert_eq!(j.features.lines3d.len(), 2);
        assert!(!j.incomplete && j.features.manhattan.is_none());
        assert!(join.next_in_order(long).is_none());
        let j = join.next_in_order(Duration::ZERO).unwrap();
        assert!(j.incomplete && j.features.id == FrameId(2));
    }

    #[test]
    fn the_tracker_waits_for_a_part_the_oldest_frame_lacks() {
        let mut join = FrameJoin::default();
        assert_eq!(join.waiting_for(), Part::Points);
        join.add_manhattan(&header(1), &[]);
        join.add_lines(&header(1), &[]);
        join.add_lines(&header(2), &[]);
        assert_eq!(join.waiting_for(), Part::Points);
        join.add_points(&header(1), &[]);
        join.add_points(&header(2), &[]);
        join.next_in_order(Duration::from_secs(60)).unwrap();
        assert_eq!(
            join.waiting_for(),
            Part::Manhattan,
            "frame 2 lacks its axes"
        );
        join.add_manhattan(&header(3), &[]);
        join.add_points(&header(3), &[]);
        join.drop_before(3);
        assert_eq!(join.waiting_for(), Part::Lines);
    }

    #[test]
    fn realtime_takes_the_newest_complete_frame() {
        let mut join = FrameJoin::default();
        for id in [3, 4, 5] {
            join.add_points(&header(id), &[]);
            join.add_lines(&header(id), &[]);
            if id != 5 {
                join.add_manhattan(&header(id), &[]);
            }
        }
        let j = join.next_newest(Duration::from_secs(60)).unwrap();
        assert_eq!(j.features.id, FrameId(4));
        assert!(join.next_newest(Duration::from_secs(60)).is_none());
        assert_eq!(
            join.next_newest(Duration::ZERO).unwrap().features.id,
            FrameId(5)
        );
    }
}
