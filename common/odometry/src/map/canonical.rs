//! A canonical memory layout for the map, so that two copies of the same map iterate
//! their arenas in the same order however they were built (incrementally by the mapper,
//! cloned, or decoded from a snapshot message). The tracker canonicalises every map it
//! receives: tracking is then bit-for-bit the same in-process and across processes.

use super::{IdMap, Map};
use std::hash::Hash;

impl Map {
    /// Rebuilds the arenas by inserting their entries in id order into tables sized
    /// for exactly that many entries.
    pub fn canonicalise(&mut self) {
        canonicalise_arena(&mut self.keyframes);
        canonicalise_arena(&mut self.points.items);
        canonicalise_arena(&mut self.lines.items);
        canonicalise_arena(&mut self.planes.items);
        canonicalise_arena(&mut self.retired);
    }
}

fn canonicalise_arena<K: Copy + Ord + Hash, V>(arena: &mut IdMap<K, V>) {
    let mut entries: Vec<(K, V)> = std::mem::take(arena).into_iter().collect();
    entries.sort_unstable_by_key(|(k, _)| *k);
    let mut fresh = IdMap::with_capacity_and_hasher(entries.len(), Default::default());
    fresh.extend(entries);
    *arena = fresh;
}
