//! k-medians clustering of binary descriptors: k-means++ seeding, then Lloyd
//! iterations whose centre is the bitwise majority of its members (the median under
//! the Hamming distance, bit by bit; DBoW2 does the same for binary descriptors).

use gfs_core::descriptor::{Descriptor, hamming};
use gfs_core::rng::SplitMix64;

/// Lloyd iterations at most: the assignment usually stops changing well before.
const MAX_ITERATIONS: usize = 20;

/// Clusters `members` (indices into `descriptors`) into at most `k` groups; returns
/// each group's centre and members. Fewer than `k` members (or fewer distinct ones)
/// give fewer groups; an empty input gives none.
pub(crate) fn cluster(
    descriptors: &[Descriptor],
    members: &[u32],
    k: usize,
    rng: &mut SplitMix64,
) -> Vec<(Descriptor, Vec<u32>)> {
    let mut centres = seed(descriptors, members, k, rng);
    let mut assignment = vec![usize::MAX; members.len()];
    for _ in 0..MAX_ITERATIONS {
        let mut changed = false;
        for (a, &m) in assignment.iter_mut().zip(members) {
            let nearest = nearest(&centres, &descriptors[m as usize]);
            changed |= *a != nearest;
            *a = nearest;
        }
        if !changed {
            break;
        }
        centres = majority(descriptors, members, &assignment, &centres);
    }
    let mut groups: Vec<(Descriptor, Vec<u32>)> =
        centres.iter().map(|&c| (c, Vec::new())).collect();
    for (&a, &m) in assignment.iter().zip(members) {
        groups[a].1.push(m);
    }
    groups.retain(|g| !g.1.is_empty());
    groups
}

/// Index of the centre nearest to `d` (the first on ties).
#[inline]
pub(crate) fn nearest(centres: &[Descriptor], d: &Descriptor) -> usize {
    let mut best = (u32::MAX, 0);
    for (i, c) in centres.iter().enumerate() {
        let dist = hamming(c, d);
        if dist < best.0 {
            best = (dist, i);
        }
    }
    best.1
}

/// Greedy k-means++ (Arthur and Vassilvitskii 2007): the first centre uniform; each
/// next one the best, by the total squared distance it leaves, of `2 + ln k`
/// candidates drawn with probability proportional to the squared distance to the
/// nearest chosen centre. Plain k-means++ too often seeds two centres in one cluster,
/// which the Lloyd iterations of a binary median cannot undo. Stops early when every
/// member coincides with a centre.
fn seed(
    descriptors: &[Descriptor],
    members: &[u32],
    k: usize,
    rng: &mut SplitMix64,
) -> Vec<Descriptor> {
    let mut centres = Vec::with_capacity(k);
    if members.is_empty() || k == 0 {
        return centres;
    }
    let trials = 2 + (k as f64).ln() as usize;
    let first = members[rng.below(members.len() as u64) as usize];
    centres.push(descriptors[first as usize]);
    let squared = |a: &Descriptor, b: &Descriptor| f64::from(hamming(a, b)).powi(2);
    let mut d2: Vec<f64> = members
        .iter()
        .map(|&m| squared(&centres[0], &descriptors[m as usize]))
        .collect();
    let mut candidate_d2 = vec![0.0; members.len()];
    let mut best_d2 = vec![0.0; members.len()];
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        if total <= 0.0 {
            break;
        }
        let mut best: Option<(f64, Descriptor)> = None;
        for _ in 0..trials {
            let mut target = rng.uniform() * total;
            let mut pick = members.len() - 1;
            for (i, &w) in d2.iter().enumerate() {
                if target < w {
                    pick = i;
                    break;
                }
                target -= w;
            }
            let centre = descriptors[members[pick] as usize];
            let mut potential = 0.0;
            for ((c, &w), &m) in candidate_d2.iter_mut().zip(&d2).zip(members) {
                *c = w.min(squared(&centre, &descriptors[m as usize]));
                potential += *c;
            }
            if best.is_none_or(|(p, _)| potential < p) {
                best = Some((potential, centre));
                std::mem::swap(&mut best_d2, &mut candidate_d2);
            }
        }
        let Some((_, centre)) = best else {
            break;
        };
        centres.push(centre);
        std::mem::swap(&mut d2, &mut best_d2);
    }
    centres
}

/// The bitwise majority of each group (a bit is set when more than half of the
/// members have it); a group left empty keeps its old centre.
fn majority(
    descriptors: &[Descriptor],
    members: &[u32],
    assignment: &[usize],
    old: &[Descriptor],
) -> Vec<Descriptor> {
    let mut counts = vec![[0u32; 256]; old.len()];
    let mut sizes = vec![0u32; old.len()];
    for (&a, &m) in assignment.iter().zip(members) {
        sizes[a] += 1;
        let d = &descriptors[m as usize];
        let count = &mut counts[a];
        for (w, &word) in d.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                count[64 * w + bits.trailing_zeros() as usize] += 1;
                bits &= bits - 1;
            }
        }
    }
    old.iter()
        .zip(counts.iter().zip(&sizes))
        .map(|(&previous, (count, &size))| {
            if size == 0 {
                return previous;
            }
            let mut c = [0u64; 4];
            for (bit, &n) in count.iter().enumerate() {
                if 2 * n > size {
                    c[bit / 64] |= 1 << (bit % 64);
                }
            }
            c
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::clustered;

    #[test]
    fn recovers_well_separated_clusters_exactly() {
        let (centres, descriptors) = clustered(6, 50, 20, 9);
        let members: Vec<u32> = (0..descriptors.len() as u32).collect();
        let groups = cluster(&descriptors, &members, 6, &mut SplitMix64::new(1));
        assert_eq!(groups.len(), 6);
        for (centre, list) in &groups {
            // One true cluster per group, all of its members, and its majority centre
            // is the true centre (20 flips in 256 bits almost never share a bit).
            let truth = list[0] as usize / 50;
            assert_eq!(list.len(), 50);
            assert!(list.iter().all(|&m| m as usize / 50 == truth));
            assert!(
                hamming(centre, &centres[truth]) <= 2,
                "{}",
                hamming(centre, &centres[truth])
            );
        }
    }

    #[test]
    fn fewer_members_than_k_give_one_group_each() {
        let (_, descriptors) = clustered(3, 1, 0, 2);
        let groups = cluster(&descriptors, &[0, 1, 2], 8, &mut SplitMix64::new(4));
        assert_eq!(groups.len(), 3);
        assert!(cluster(&descriptors, &[], 8, &mut SplitMix64::new(4)).is_empty());
        // Identical descriptors: one group.
        let same = vec![descriptors[0]; 5];
        assert_eq!(
            cluster(&same, &[0, 1, 2, 3, 4], 3, &mut SplitMix64::new(4)).len(),
            1
        );
    }
}
