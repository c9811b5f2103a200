//! A map taken apart into its arenas and counters, and put back together: what a map
//! file stores of it ([`crate::map_file`]), without the keyframes' landmark slots,
//! which follow from the landmarks' observations.

use super::{IdMap, KeyFrame, MapLine, MapPlane, MapPoint, RetiredKeyFrame, Store};
use gfs_core::ids::{KeyFrameId, MapLineId, MapPlaneId, MapPointId};

/// The counters and bookkeeping of a map besides its keyframes and landmarks.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct MapCounters {
    /// The next keyframe id.
    pub next_keyframe: u64,
    /// The next map point, line and plane ids.
    pub next_landmarks: [u64; 3],
    /// Loop corrections applied so far.
    pub corrections: u64,
    /// The newest keyframe when the last loop was closed.
    pub closed_through: Option<KeyFrameId>,
}

/// A map's parts, each arena in id order.
pub(crate) struct MapParts {
    pub counters: MapCounters,
    pub keyframes: Vec<KeyFrame>,
    pub points: Vec<(MapPointId, MapPoint)>,
    pub lines: Vec<(MapLineId, MapLine)>,
    pub planes: Vec<(MapPlaneId, MapPlane)>,
    pub retired: Vec<(KeyFrameId, RetiredKeyFrame)>,
}

/// An arena of `entries` laid out as [`super::Map::canonicalise`] lays it out (the
/// entries come in id order).
fn arena<K: Copy + Eq + std::hash::Hash, V>(entries: Vec<(K, V)>) -> IdMap<K, V> {
    let mut arena = IdMap::with_capacity_and_hasher(entries.len(), Default::default());
    arena.extend(entries);
    arena
}

/// `arena`'s entries in id order.
fn sorted<K: Copy + Ord, V>(arena: &IdMap<K, V>) -> Vec<(K, &V)> {
    let mut entries: Vec<_> = arena.iter().map(|(k, v)| (*k, v)).collect();
    entries.sort_unstable_by_key(|(k, _)| *k);
    entries
}

impl super::Map {
    /// The counters and bookkeeping besides keyframes and landmarks.
    pub(crate) fn counters(&self) -> MapCounters {
        MapCounters {
            next_keyframe: self.next_keyframe,
            next_landmarks: [self.points.next, self.lines.next, self.planes.next],
            corrections: self.corrections,
            closed_through: self.closed_through,
        }
    }

    /// The keyframes in id order.
    pub(crate) fn sorted_keyframes(&self) -> Vec<&KeyFrame> {
        sorted(&self.keyframes)
            .into_iter()
            .map(|(_, k)| k)
            .collect()
    }

    /// The map points in id order.
    pub(crate) fn sorted_points(&self) -> Vec<(MapPointId, &MapPoint)> {
        sorted(&self.points.items)
    }

    /// The map lines in id order.
    pub(crate) fn sorted_lines(&self) -> Vec<(MapLineId, &MapLine)> {
        sorted(&self.lines.items)
    }

    /// The map planes in id order.
    pub(crate) fn sorted_planes(&self) -> Vec<(MapPlaneId, &MapPlane)> {
        sorted(&self.planes.items)
    }

    /// The retired keyframes in id order.
    pub(crate) fn sorted_retired(&self) -> Vec<(KeyFrameId, &RetiredKeyFrame)> {
        sorted(&self.retired)
    }

    /// The map of `parts`, as they are: the caller linked the keyframes' slots to the
    /// landmarks' observations, and [`super::Map::validate`] checks the result.
    pub(crate) fn from_parts(parts: MapParts) -> Self {
        let MapParts {
            counters,
            keyframes,
            points,
            lines,
            planes,
            retired,
        } = parts;
        let [next_point, next_line, next_plane] = counters.next_landmarks;
        Self {
            keyframes: arena(keyframes.into_iter().map(|k| (k.id, k)).collect()),
            points: Store {
                items: arena(points),
                next: next_point,
            },
            lines: Store {
                items: arena(lines),
                next: next_line,
            },
            planes: Store {
                items: arena(planes),
                next: next_plane,
            },
            next_keyframe: counters.next_keyframe,
            retired: arena(retired),
            corrections: counters.corrections,
            closed_through: counters.closed_through,
        }
    }
}
