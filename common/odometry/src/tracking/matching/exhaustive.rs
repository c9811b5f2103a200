//! Exhaustive descriptor matching with the ratio test, for when no pose prediction can
//! narrow the search (tracking against a keyframe, relocalisation).

use crate::frontend::features::Descriptor;
use gfs_points::best_two;

/// Matches every `query` descriptor to its nearest `train` descriptor, keeping a match
/// when its distance is at most `max_distance` and below `ratio` times the second best;
/// a train descriptor matched twice keeps only the closer query. `out[i]` is the train
/// index of query `i`.
pub fn match_descriptors(
    query: &[Descriptor],
    train: &[Descriptor],
    max_distance: u32,
    ratio: f32,
    out: &mut Vec<Option<usize>>,
) {
    out.clear();
    out.resize(query.len(), None);
    let mut owner: Vec<Option<(usize, u32)>> = vec![None; train.len()];
    for (qi, q) in query.iter().enumerate() {
        let Some(m) = best_two(q, train.iter().enumerate()) else {
            continue;
        };
        let (best, best_index) = (m.distance, m.index);
        if best > max_distance || !m.passes_ratio(ratio) {
            continue;
        }
        match owner[best_index] {
            Some((_, d)) if d <= best => {}
            Some((previous, _)) => {
                out[previous] = None;
                owner[best_index] = Some((qi, best));
                out[qi] = Some(best_index);
            }
            None => {
                owner[best_index] = Some((qi, best));
                out[qi] = Some(best_index);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_distinct_descriptors_match_and_ambiguous_ones_do_not() {
        let a = [0u64, 0, 0, 0];
        let b = [u64::MAX, 0, 0, 0];
        let c = [0u64, u64::MAX, 0, 0];
        let a_noisy = [0b111u64, 0, 0, 0];
        let mut out = Vec::new();
        match_descriptors(&[a_noisy, b], &[c, a, b], 50, 0.8, &mut out);
        assert_eq!(out, vec![Some(1), Some(2)]);
        // Two identical train descriptors: the ratio test refuses to choose.
        match_descriptors(&[a], &[a, a], 50, 0.8, &mut out);
        assert_eq!(out, vec![None]);
    }
}
