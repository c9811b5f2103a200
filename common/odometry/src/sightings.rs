//! How often the tracker predicted and matched each landmark: the mapper culls
//! landmarks on these counts (`found / visible`, ORB-SLAM2 `MapPointCulling`). The
//! tracker only reads the map, so it counts here, and the counts travel to the map's
//! owner with the next keyframe request.

use crate::map::{IdMap, Landmark, LandmarkId, Map};
use gfs_core::ids::{MapLineId, MapPointId};
use serde::{Deserialize, Serialize};

/// Frames in whose view a landmark was predicted to be, and frames that matched it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SightingCount {
    /// Frames in whose view it was predicted to be.
    pub visible: u32,
    /// Frames in which it was matched.
    pub found: u32,
}

/// The sightings counted since the last keyframe request.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sightings {
    points: IdMap<MapPointId, SightingCount>,
    lines: IdMap<MapLineId, SightingCount>,
}

impl Sightings {
    /// The points were predicted in view.
    pub fn points_visible(&mut self, ids: &[MapPointId]) {
        for id in ids {
            self.points.entry(*id).or_default().visible += 1;
        }
    }

    /// The points were matched.
    pub fn points_found<'a>(&mut self, ids: impl IntoIterator<Item = &'a MapPointId>) {
        for id in ids {
            self.points.entry(*id).or_default().found += 1;
        }
    }

    /// The lines were predicted in view.
    pub fn lines_visible(&mut self, ids: &[MapLineId]) {
        for id in ids {
            self.lines.entry(*id).or_default().visible += 1;
        }
    }

    /// The lines were matched.
    pub fn lines_found<'a>(&mut self, ids: impl IntoIterator<Item = &'a MapLineId>) {
        for id in ids {
            self.lines.entry(*id).or_default().found += 1;
        }
    }

    /// The count of a point (zero when never seen).
    pub fn point(&self, id: MapPointId) -> SightingCount {
        self.points.get(&id).copied().unwrap_or_default()
    }

    /// The count of a line (zero when never seen).
    pub fn line(&self, id: MapLineId) -> SightingCount {
        self.lines.get(&id).copied().unwrap_or_default()
    }

    /// True when nothing was counted.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty() && self.lines.is_empty()
    }

    /// Adds the counts to the landmarks of `map` that still exist (the others were
    /// culled or merged since the tracker saw them).
    pub fn add_to(&self, map: &mut Map) {
        add_counts(map, &self.points);
        add_counts(map, &self.lines);
    }
}

fn add_counts<I: LandmarkId>(map: &mut Map, counts: &IdMap<I, SightingCount>) {
    for (id, c) in counts {
        if let Some(landmark) = map.landmark_mut(*id) {
            let (visible, found) = landmark.sightings_mut();
            *visible = visible.saturating_add(c.visible);
            *found = found.saturating_add(c.found);
        }
    }
}
