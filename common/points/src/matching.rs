//! Descriptor distances and the best / second-best search the tracker's matchers use.

use crate::keypoint::Descriptor;
pub use gfs_core::descriptor::hamming;

/// The closest candidate to a query and the distance of the runner-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BestMatch {
    /// Identifier of the closest candidate (as given to [`best_two`]).
    pub index: usize,
    /// Its Hamming distance.
    pub distance: u32,
    /// Distance of the second-closest candidate; `u32::MAX` when there was only one.
    pub second: u32,
    /// Identifier of the second-closest candidate; `usize::MAX` when there was only one.
    pub second_index: usize,
}

impl BestMatch {
    /// Lowe's ratio test as ORB-SLAM2's exhaustive matchers apply it (`SearchByBoW`):
    /// accepted when `distance < ratio * second` (always accepted without a runner-up).
    pub fn passes_ratio(&self, ratio: f32) -> bool {
        self.second == u32::MAX || (self.distance as f32) < ratio * self.second as f32
    }

    /// The same test as ORB-SLAM2's projection matchers apply it (`SearchByProjection`):
    /// a tie at exactly `ratio * second` is accepted.
    pub fn passes_ratio_or_ties(&self, ratio: f32) -> bool {
        self.second == u32::MAX || (self.distance as f32) <= ratio * self.second as f32
    }
}

/// The closest and second-closest of `candidates` (pairs of an identifier and a
/// descriptor) to `query`; `None` when there is no candidate. Ties keep the first.
pub fn best_two<'a>(
    query: &Descriptor,
    candidates: impl IntoIterator<Item = (usize, &'a Descriptor)>,
) -> Option<BestMatch> {
    let mut best: Option<BestMatch> = None;
    for (index, d) in candidates {
        let distance = hamming(query, d);
        match &mut best {
            None => {
                best = Some(BestMatch {
                    index,
                    distance,
                    second: u32::MAX,
                    second_index: usize::MAX,
                })
            }
            Some(b) if distance < b.distance => {
                b.second = b.distance;
                b.second_index = b.index;
                b.distance = distance;
                b.index = index;
            }
            Some(b) if distance < b.second => {
                b.second = distance;
                b.second_index = index;
            }
            Some(_) => {}
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_and_ratio() {
        let a = [0u64; 4];
        let b = [u64::MAX, 0, 1, 0b111];
        let cands = [[0b1u64, 0, 0, 0], [0b1111, 0, 0, 0], [0b11, 0, 0, 0]];
        let m = best_two(&a, cands.iter().enumerate().map(|(i, d)| (i + 10, d))).unwrap();
        assert_eq!(
            m,
            BestMatch {
                index: 10,
                distance: 1,
                second: 2,
                second_index: 12,
            }
        );
        assert!(m.passes_ratio(0.6));
        let close = BestMatch {
            index: 0,
            distance: 50,
            second: 60,
            second_index: 1,
        };
        assert!(!close.passes_ratio(0.8) && close.passes_ratio(0.9));
        // A tie at exactly the ratio: refused by the strict test, accepted by the other.
        let tie = BestMatch {
            index: 0,
            distance: 45,
            second: 60,
            second_index: 1,
        };
        assert!(!tie.passes_ratio(0.75) && tie.passes_ratio_or_ties(0.75));
        assert!(!close.passes_ratio_or_ties(0.8));
        assert_eq!(best_two(&a, std::iter::empty()), None);
        let alone = best_two(&a, [(3, &b)]).unwrap();
        assert_eq!((alone.index, alone.second), (3, u32::MAX));
        assert!(alone.passes_ratio(0.1));
    }
}
