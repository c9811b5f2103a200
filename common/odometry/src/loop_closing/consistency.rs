//! Temporal consistency of loop candidates (ORB-SLAM2 `DetectLoop`): a candidate stands
//! for its group (itself and its connected keyframes), and is believed only when groups
//! that share a keyframe with it were candidates at the previous keyframes too, for
//! `consistent_keyframes` keyframes in a row. A single look-alike keyframe does not make
//! a loop; a place really come back to keeps proposing the same neighbourhood.

use crate::map::Map;
use gfs_core::ids::KeyFrameId;

/// The candidate groups of the last keyframe, each with the number of consecutive
/// keyframes it has been consistent over.
#[derive(Debug, Default)]
pub struct ConsistentGroups {
    groups: Vec<(Vec<KeyFrameId>, u32)>,
}

impl ConsistentGroups {
    /// Takes in the candidates of the new keyframe and returns those consistent over at
    /// least `required` keyframes (this one included), in their order.
    pub fn update(
        &mut self,
        map: &Map,
        candidates: &[KeyFrameId],
        required: u32,
    ) -> Vec<KeyFrameId> {
        let mut next = Vec::with_capacity(candidates.len());
        let mut accepted = Vec::new();
        for &candidate in candidates {
            let mut group: Vec<KeyFrameId> = std::iter::once(candidate)
                .chain(map.connected(candidate).into_iter().map(|(k, _)| k))
                .collect();
            group.sort_unstable();
            let count = 1 + self
                .groups
                .iter()
                .filter(|(previous, _)| shares(previous, &group))
                .map(|(_, n)| *n)
                .max()
                .unwrap_or(0);
            if count >= required {
                accepted.push(candidate);
            }
            next.push((group, count));
        }
        self.groups = next;
        accepted
    }

    /// Forgets every group (after a loop was closed, or while loops are not looked for).
    pub fn clear(&mut self) {
        self.groups.clear();
    }
}

/// True when the sorted lists share an id.
fn shares(a: &[KeyFrameId], b: &[KeyFrameId]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return true,
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_candidate_is_accepted_once_its_group_came_back_at_enough_keyframes_in_a_row() {
        let map = Map::default();
        let mut groups = ConsistentGroups::default();
        let (a, b) = (KeyFrameId(5), KeyFrameId(9));
        assert!(groups.update(&map, &[a], 3).is_empty());
        assert!(groups.update(&map, &[a, b], 3).is_empty());
        assert_eq!(groups.update(&map, &[b, a], 3), vec![a]);
        // A keyframe without candidates breaks the run.
        assert!(groups.update(&map, &[], 3).is_empty());
        assert!(groups.update(&map, &[a], 2).is_empty());
        assert_eq!(groups.update(&map, &[a], 2), vec![a]);
        groups.clear();
        assert!(groups.update(&map, &[a], 2).is_empty());
    }
}
