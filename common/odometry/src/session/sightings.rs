//! The tracker's landmark sightings between two maps from the mapper. The tracker counts
//! `visible` / `found` on its own copy of the map; the mapper culls on those counts, so
//! each keyframe request carries what was counted since the copy arrived.

use super::messages::SightingCount;
use crate::map::{IdMap, Map};
use gfs_core::ids::{MapLineId, MapPointId};
use std::hash::Hash;

/// The counts of every landmark when they were last reported or received.
#[derive(Debug, Default)]
pub struct SightingBaseline {
    points: IdMap<MapPointId, (u32, u32)>,
    lines: IdMap<MapLineId, (u32, u32)>,
}

impl SightingBaseline {
    /// Takes the counts of `map` as the new baseline.
    pub fn reset(&mut self, map: &Map) {
        self.points.clear();
        self.points.extend(
            map.point_ids()
                .filter_map(|id| map.point(id).map(|p| (id, (p.visible, p.found)))),
        );
        self.lines.clear();
        self.lines.extend(
            map.line_ids()
                .filter_map(|id| map.line(id).map(|l| (id, (l.visible, l.found)))),
        );
    }

    /// The counts added in `map` since the baseline, in id order (landmarks the
    /// baseline does not know count from zero).
    pub fn since(
        &self,
        map: &Map,
    ) -> (
        Vec<SightingCount<MapPointId>>,
        Vec<SightingCount<MapLineId>>,
    ) {
        let points = increments(
            map.point_ids()
                .filter_map(|id| map.point(id).map(|p| (id, p.visible, p.found))),
            &self.points,
        );
        let lines = increments(
            map.line_ids()
                .filter_map(|id| map.line(id).map(|l| (id, l.visible, l.found))),
            &self.lines,
        );
        (points, lines)
    }
}

fn increments<I: Copy + Ord + Hash>(
    current: impl Iterator<Item = (I, u32, u32)>,
    baseline: &IdMap<I, (u32, u32)>,
) -> Vec<SightingCount<I>> {
    let mut out: Vec<_> = current
        .filter_map(|(id, visible, found)| {
            let (v0, f0) = baseline.get(&id).copied().unwrap_or((0, 0));
            let count = SightingCount {
                id,
                visible: visible.saturating_sub(v0),
                found: found.saturating_sub(f0),
            };
            (count.visible > 0 || count.found > 0).then_some(count)
        })
        .collect();
    out.sort_unstable_by_key(|c| c.id);
    out
}

/// Adds sighting counts to the landmarks of `map` that still exist.
pub fn apply_sightings(
    map: &mut Map,
    points: &[SightingCount<MapPointId>],
    lines: &[SightingCount<MapLineId>],
) {
    for c in points {
        if let Some(p) = map.point_mut(c.id) {
            p.visible = p.visible.saturating_add(c.visible);
            p.found = p.found.saturating_add(c.found);
        }
    }
    for c in lines {
        if let Some(l) = map.line_mut(c.id) {
            l.visible = l.visible.saturating_add(c.visible);
            l.found = l.found.saturating_add(c.found);
        }
    }
}
