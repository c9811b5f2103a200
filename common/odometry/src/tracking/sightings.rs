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

    /// The counts so far, leaving this accumulator empty with its memory kept (the
    /// tracker counts into it every frame; only a keyframe request takes a copy).
    pub fn take(&mut self) -> Sightings {
        let taken = self.clone();
        self.points.clear();
        self.lines.clear();
        taken
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, first_keyframe};

    #[test]
    fn counts_accumulate_and_reach_only_landmarks_that_still_exist() {
        let (mut map, _, _) = first_keyframe(&Scene::new(10, 2), &OdometryConfig::default());
        let points: Vec<MapPointId> = map.point_ids().collect();
        let (a, b) = (points[0], points[1]);
        let line = map.line_ids().next().expect("a line");
        let mut sightings = Sightings::default();
        assert!(sightings.is_empty());
        sightings.points_visible(&[a, b, a]);
        sightings.points_found([a].iter());
        sightings.lines_visible(&[line]);
        sightings.points_visible(&[MapPointId(999)]);
        assert_eq!(
            sightings.point(a),
            SightingCount {
                visible: 2,
                found: 1
            }
        );
        assert_eq!(
            sightings.line(line),
            SightingCount {
                visible: 1,
                found: 0
            }
        );
        map.remove_landmark(b);
        sightings.add_to(&mut map);
        // New landmarks start at one sighting of each (their creating keyframe).
        let p = map.point(a).expect("a");
        assert_eq!((p.visible, p.found), (3, 2));
        let l = map.line(line).expect("line");
        assert_eq!((l.visible, l.found), (2, 1));
        assert!(map.point(MapPointId(999)).is_none());
    }

    #[test]
    fn taking_the_counts_empties_the_accumulator() {
        let mut sightings = Sightings::default();
        sightings.points_found([MapPointId(1)].iter());
        let taken = sightings.take();
        assert!(sightings.is_empty());
        assert_eq!(taken.point(MapPointId(1)).found, 1);
    }

    #[test]
    fn counts_saturate_instead_of_wrapping() {
        let (mut map, _, _) = first_keyframe(&Scene::new(4, 0), &OdometryConfig::default());
        let a = map.point_ids().next().expect("a point");
        map.point_mut(a).expect("a").visible = u32::MAX;
        let mut sightings = Sightings::default();
        sightings.points_visible(&[a]);
        sightings.add_to(&mut map);
        assert_eq!(map.point(a).expect("a").visible, u32::MAX);
    }
}
