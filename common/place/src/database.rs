//! The keyframe database: an inverted file from each word to the keyframes that hold
//! it, for retrieval by bag-of-words similarity.

use crate::bow::{BowVector, l1_term};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::hash::Hash;

/// Keyframes' bag-of-words vectors with an inverted file (word -> keyframes), so that
/// a query visits only the keyframes sharing a word with it.
///
/// `Id` is the caller's keyframe id (e.g. `gfs_core::ids::KeyFrameId`, or `u64`).
/// Internally each keyframe has a dense slot; removed slots are reused.
///
/// It serialises as its word count and its `(id, vector)` entries, and is rebuilt from
/// them on deserialisation, so that a checkpoint or message cannot hold an inconsistent
/// index.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(
    from = "DatabaseSnapshot<Id>",
    into = "DatabaseSnapshot<Id>",
    bound(
        serialize = "Id: Serialize + Copy + Eq + Hash",
        deserialize = "Id: Deserialize<'de> + Copy + Eq + Hash"
    )
)]
pub struct KeyFrameDatabase<Id> {
    /// Per word: `(slot, weight)` of the keyframes holding it.
    inverted: Vec<Vec<(u32, f64)>>,
    /// Per slot: its id and vector, `None` when free.
    slots: Vec<Option<(Id, BowVector)>>,
    free: Vec<u32>,
    slot_of: HashMap<Id, u32>,
}

/// The serialised form of a [`KeyFrameDatabase`].
#[derive(Serialize, Deserialize)]
struct DatabaseSnapshot<Id> {
    words: u32,
    keyframes: Vec<(Id, BowVector)>,
}

impl<Id: Copy + Eq + Hash> From<KeyFrameDatabase<Id>> for DatabaseSnapshot<Id> {
    fn from(database: KeyFrameDatabase<Id>) -> Self {
        Self {
            words: database.inverted.len() as u32,
            keyframes: database.slots.into_iter().flatten().collect(),
        }
    }
}

impl<Id: Copy + Eq + Hash> From<DatabaseSnapshot<Id>> for KeyFrameDatabase<Id> {
    fn from(snapshot: DatabaseSnapshot<Id>) -> Self {
        let mut database = Self::new(snapshot.words as usize);
        for (id, bow) in &snapshot.keyframes {
            database.add(*id, bow);
        }
        database
    }
}

impl<Id: Copy + Eq + Hash> KeyFrameDatabase<Id> {
    /// An empty database for a vocabulary of `words` words
    /// ([`crate::Vocabulary::num_words`]); words of a vector outside it are ignored.
    pub fn new(words: usize) -> Self {
        Self {
            inverted: vec![Vec::new(); words],
            slots: Vec::new(),
            free: Vec::new(),
            slot_of: HashMap::new(),
        }
    }

    /// Number of keyframes.
    pub fn len(&self) -> usize {
        self.slot_of.len()
    }

    /// True when it holds no keyframe.
    pub fn is_empty(&self) -> bool {
        self.slot_of.is_empty()
    }

    /// True when `id` is in the database.
    pub fn contains(&self, id: Id) -> bool {
        self.slot_of.contains_key(&id)
    }

    /// The vector stored for `id`.
    pub fn get(&self, id: Id) -> Option<&BowVector> {
        let slot = *self.slot_of.get(&id)?;
        self.slots[slot as usize].as_ref().map(|(_, v)| v)
    }

    /// Adds keyframe `id` with its vector, replacing an earlier entry of the same id.
    pub fn add(&mut self, id: Id, bow: &BowVector) {
        self.remove(id);
        let slot = match self.free.pop() {
            Some(s) => s,
            None => {
                self.slots.push(None);
                (self.slots.len() - 1) as u32
            }
        };
        for &(word, weight) in bow.entries() {
            if let Some(list) = self.inverted.get_mut(word as usize) {
                list.push((slot, weight));
            }
        }
        self.slots[slot as usize] = Some((id, bow.clone()));
        self.slot_of.insert(id, slot);
    }

    /// Removes keyframe `id`; returns whether it was there. Costs the length of the
    /// inverted lists of its words.
    pub fn remove(&mut self, id: Id) -> bool {
        let Some(slot) = self.slot_of.remove(&id) else {
            return false;
        };
        if let Some((_, bow)) = self.slots[slot as usize].take() {
            for &(word, _) in bow.entries() {
                if let Some(list) = self.inverted.get_mut(word as usize) {
                    list.retain(|e| e.0 != slot);
                }
            }
        }
        self.free.push(slot);
        true
    }

    /// The keyframes most similar to `bow` (L1 score of [`crate::score`], in `[0, 1]`),
    /// best first, at most `max_results`, skipping those for which `exclude` is true
    /// (e.g. the query keyframe's covisible neighbours) and those sharing no word.
    /// Ties are broken by slot order, so results are reproducible.
    pub fn query(
        &self,
        bow: &BowVector,
        max_results: usize,
        exclude: impl Fn(Id) -> bool,
    ) -> Vec<(Id, f64)> {
        let mut sums = vec![0.0f64; self.slots.len()];
        let mut touched = Vec::new();
        for &(word, a) in bow.entries() {
            let Some(list) = self.inverted.get(word as usize) else {
                continue;
            };
            for &(slot, b) in list {
                let s = &mut sums[slot as usize];
                if *s == 0.0 {
                    touched.push(slot);
                }
                *s += l1_term(a, b);
            }
        }
        let mut results: Vec<(u32, f64)> = touched
            .into_iter()
            .map(|slot| (slot, 0.5 * sums[slot as usize]))
            .filter(|&(slot, _)| {
                self.slots[slot as usize]
                    .as_ref()
                    .is_some_and(|(id, _)| !exclude(*id))
            })
            .collect();
        results.sort_unstable_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        results.truncate(max_results);
        results
            .into_iter()
            .filter_map(|(slot, s)| {
                self.slots[slot as usize]
                    .as_ref()
                    .map(|(id, _)| (*id, s.min(1.0)))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::score;

    fn bow(words: &[(u32, f64)]) -> BowVector {
        BowVector::from_weights(words.to_vec())
    }

    #[test]
    fn query_ranks_by_score_and_honours_exclusions_and_removal() {
        let mut db = KeyFrameDatabase::<u64>::new(10);
        let a = bow(&[(1, 1.0), (2, 1.0), (3, 1.0)]);
        let b = bow(&[(1, 1.0), (2, 1.0), (7, 1.0)]);
        let c = bow(&[(8, 1.0), (9, 1.0)]);
        db.add(10, &a);
        db.add(20, &b);
        db.add(30, &c);
        assert_eq!(db.len(), 3);
        let q = bow(&[(1, 1.0), (2, 1.0), (3, 0.5)]);
        let hits = db.query(&q, 5, |_| false);
        assert_eq!(hits.len(), 2, "c shares no word");
        assert_eq!(hits[0].0, 10);
        assert!((hits[0].1 - score(&q, &a)).abs() < 1e-12);
        assert!((hits[1].1 - score(&q, &b)).abs() < 1e-12);
        assert_eq!(db.query(&q, 1, |_| false).len(), 1);
        assert_eq!(db.query(&q, 5, |id| id == 10)[0].0, 20);
        assert!(db.remove(10));
        assert!(!db.remove(10));
        assert_eq!(db.query(&q, 5, |_| false)[0].0, 20);
        // The freed slot is reused; re-adding an id replaces its vector.
        db.add(40, &a);
        db.add(40, &a);
        assert_eq!(db.len(), 3);
        assert_eq!(db.query(&q, 5, |_| false)[0], (40, score(&q, &a)));
        // Words outside the vocabulary are ignored.
        db.add(50, &bow(&[(25, 1.0), (4, 1.0)]));
        assert_eq!(db.query(&bow(&[(25, 1.0)]), 1, |_| false), vec![]);
        assert_eq!(db.query(&bow(&[(4, 1.0)]), 1, |_| false), vec![(50, 0.5)]);
        // A checkpoint restores the same answers.
        let config = bincode::config::standard();
        let bytes = bincode::serde::encode_to_vec(&db, config).expect("encodable");
        let (back, _): (KeyFrameDatabase<u64>, usize) =
            bincode::serde::decode_from_slice(&bytes, config).expect("decodable");
        assert_eq!(back.query(&q, 5, |_| false), db.query(&q, 5, |_| false));
        assert_eq!(back.len(), db.len());
        assert_eq!(back.get(20), db.get(20));
    }
}
