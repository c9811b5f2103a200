//! Keyframes that left the map (culled as redundant, bounded out, or dropped with a
//! lost map): a frame tracked against one still needs the loop corrections that came
//! after it, so each retired keyframe stays attached to a keyframe that stayed (its
//! parent) and follows the corrections the parent receives, as ORB-SLAM2's spanning
//! tree does for the trajectory it saves.

use super::Map;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

/// A keyframe no longer in the map.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct RetiredKeyFrame {
    /// The keyframe it stays attached to (`None`: it was the last one of its map).
    pub parent: Option<KeyFrameId>,
    /// The parent's loop correction when this one was retired.
    pub parent_correction: Isometry3<f64>,
    /// Its own loop correction when it was retired.
    pub correction: Isometry3<f64>,
}

/// Longest chain of parents followed (a chain is acyclic: a parent was in the map when
/// its child was retired; the bound only guards against a corrupted map).
const MAX_CHAIN: usize = 100_000;

impl Map {
    /// Records keyframe `id` (still in the map) as retired.
    pub(super) fn retire(&mut self, id: KeyFrameId) {
        let Some(keyframe) = self.keyframes.get(&id) else {
            return;
        };
        let correction = keyframe.loop_correction;
        let parent = self
            .covisible(id, 1)
            .first()
            .map(|(k, _)| *k)
            .or_else(|| self.keyframe_ids().into_iter().rev().find(|k| *k != id));
        let parent_correction = parent
            .and_then(|p| self.keyframes.get(&p))
            .map_or(Isometry3::identity(), |p| p.loop_correction);
        self.retired.insert(
            id,
            RetiredKeyFrame {
                parent,
                parent_correction,
                correction,
            },
        );
    }

    /// The loop corrections (`new_from_old`, world frame) a keyframe in the map or
    /// retired from it has received so far; `None` for an id never seen. A retired
    /// keyframe receives what its parent received after it was retired.
    pub fn keyframe_correction(&self, id: KeyFrameId) -> Option<Isometry3<f64>> {
        // Corrections since retirement, collected along the chain of parents.
        let mut after = Isometry3::identity();
        let mut at = id;
        for _ in 0..MAX_CHAIN {
            if let Some(k) = self.keyframes.get(&at) {
                return Some(k.loop_correction * after);
            }
            let retired = self.retired.get(&at)?;
            let resolved = retired
                .parent
                .filter(|p| self.keyframes.contains_key(p) || self.retired.contains_key(p));
            match resolved {
                Some(parent) => {
                    after = retired.parent_correction.inverse() * retired.correction * after;
                    at = parent;
                }
                None => return Some(retired.correction * after),
            }
        }
        None
    }

    /// Loop corrections applied to the map so far.
    pub fn corrections(&self) -> u64 {
        self.corrections
    }

    /// Counts a loop correction (the tracker re-anchors its pose when it sees the count
    /// change) and records the newest keyframe it made consistent with the loop.
    pub fn count_correction(&mut self) {
        self.corrections += 1;
        self.closed_through = self.keyframes.keys().max().copied();
    }

    /// The newest keyframe of the map when the last loop was closed (`None` before the
    /// first): the keyframes up to it agree with each other around the loop, those made
    /// since drift from them again until the next loop.
    pub fn closed_through(&self) -> Option<KeyFrameId> {
        self.closed_through
    }
}
