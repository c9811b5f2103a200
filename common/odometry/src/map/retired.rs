//! Keyframes that left the map (culled as redundant, bounded out, or dropped with a
//! lost map): a frame tracked against one still needs its final pose, so each keeps its
//! pose relative to a keyframe that stayed (its parent), as ORB-SLAM2's spanning tree
//! does for the trajectory it saves. A loop correction moves the parent; the retired
//! keyframe follows it.

use super::Map;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

/// A keyframe no longer in the map.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct RetiredKeyFrame {
    /// The keyframe it is anchored to (`None`: it was the last one of its map).
    pub parent: Option<KeyFrameId>,
    /// `parent_from_camera` when it was removed.
    pub parent_from_camera: Isometry3<f64>,
    /// `world_from_camera` when it was removed (used when the chain of parents ends
    /// outside the map).
    pub world_from_camera: Isometry3<f64>,
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
        let world_from_camera = keyframe.world_from_camera();
        let parent = self
            .covisible(id, 1)
            .first()
            .map(|(k, _)| *k)
            .or_else(|| self.keyframe_ids().into_iter().rev().find(|k| *k != id));
        let parent_from_camera = parent
            .and_then(|p| self.keyframes.get(&p))
            .map_or(Isometry3::identity(), |p| {
                p.camera_from_world * world_from_camera
            });
        self.retired.insert(
            id,
            RetiredKeyFrame {
                parent,
                parent_from_camera,
                world_from_camera,
            },
        );
    }

    /// The current best `world_from_camera` of a keyframe in the map or retired from
    /// it; `None` for an id never seen.
    pub fn keyframe_pose(&self, id: KeyFrameId) -> Option<Isometry3<f64>> {
        let mut chain = Isometry3::identity();
        let mut at = id;
        for _ in 0..MAX_CHAIN {
            if let Some(k) = self.keyframes.get(&at) {
                return Some(k.world_from_camera() * chain);
            }
            let retired = self.retired.get(&at)?;
            match retired.parent {
                Some(parent) => {
                    chain = retired.parent_from_camera * chain;
                    at = parent;
                }
                None => return Some(retired.world_from_camera * chain),
            }
        }
        None
    }

    /// Loop corrections applied to the map so far.
    pub fn corrections(&self) -> u64 {
        self.corrections
    }

    /// Counts a loop correction (the tracker re-anchors its pose when it sees the count
    /// change).
    pub fn count_correction(&mut self) {
        self.corrections += 1;
    }
}
