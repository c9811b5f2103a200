//! Pairing the poses of two trajectories by timestamp, as evo's
//! `sync.associate_trajectories` does.

use super::Trajectory;

/// evo's default largest stamp difference of an associated pair (`--t_max_diff`), s.
pub const EVO_MAX_DIFF_S: f64 = 0.01;

/// Index of the stamp of `sorted` closest to `t` (the first one on a tie, like numpy's
/// `argmin`); `None` when `sorted` is empty.
pub(crate) fn closest_index(sorted: &[f64], t: f64) -> Option<usize> {
    if sorted.is_empty() {
        return None;
    }
    let k = sorted.partition_point(|&s| s < t);
    if k == 0 {
        return Some(0);
    }
    if k == sorted.len() {
        return Some(k - 1);
    }
    // On equal distance the lower index wins.
    if (t - sorted[k - 1]).abs() <= (sorted[k] - t).abs() {
        Some(k - 1)
    } else {
        Some(k)
    }
}

/// Associates `first` with `second` the way evo does: for every stamp of the trajectory
/// with fewer poses (`first` on a tie), the closest stamp of the other one, kept when at
/// most `max_diff` seconds away. Returns `(index in first, index in second)` pairs in the
/// order of the shorter trajectory.
///
/// With the denser trajectory as the searched one, two poses are associated with the
/// same partner only when that partner is the closest of both, which for the usual
/// 100 Hz ground truth against 30 Hz estimates does not happen.
pub fn associate(first: &Trajectory, second: &Trajectory, max_diff: f64) -> Vec<(usize, usize)> {
    let second_longer = second.len() > first.len();
    let (short, long) = if second_longer {
        (first.seconds(), second.seconds())
    } else {
        (second.seconds(), first.seconds())
    };
    let mut pairs = Vec::new();
    for (i_short, &t) in short.iter().enumerate() {
        if let Some(i_long) = closest_index(&long, t)
            && (long[i_long] - t).abs() <= max_diff
        {
            pairs.push(if second_longer {
                (i_short, i_long)
            } else {
                (i_long, i_short)
            });
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::stamp::Stamp;
    use nalgebra::Isometry3;

    fn stamps(ts: &[f64]) -> Trajectory {
        let mut t = Trajectory::new();
        for &s in ts {
            t.push(Stamp::from_secs(s).unwrap(), Isometry3::identity());
        }
        t
    }

    #[test]
    fn closest_index_breaks_ties_towards_the_lower_index() {
        let s = [0.0, 1.0, 2.0];
        assert_eq!(closest_index(&s, -5.0), Some(0));
        assert_eq!(closest_index(&s, 0.5), Some(0));
        assert_eq!(closest_index(&s, 0.51), Some(1));
        assert_eq!(closest_index(&s, 9.0), Some(2));
        assert_eq!(closest_index(&[], 1.0), None);
    }

    #[test]
    fn association_with_stamp_jitter_keeps_pairs_within_10_ms() {
        // Ground truth at 100 Hz; the estimate at ~30 Hz with jitter of up to +-4 ms,
        // and two frames 15 ms and 30 ms away from any ground-truth stamp.
        let gt: Vec<f64> = (0..200).map(|i| 100.0 + i as f64 * 0.01).collect();
        let jitter = [0.004, -0.003, 0.0, 0.002, -0.004, 0.001];
        let mut est: Vec<f64> = (0..60)
            .map(|k| 100.0 + k as f64 * 0.033 + jitter[k % jitter.len()])
            .collect();
        est.push(102.005 + 0.010); // 102.015: nearest gt 101.99 is 25 ms away
        est.push(102.03);
        let pairs = associate(&stamps(&gt), &stamps(&est), EVO_MAX_DIFF_S);
        assert_eq!(pairs.len(), 60);
        for &(i, j) in &pairs {
            assert!(
                (gt[i] - est[j]).abs() <= 0.005 + 1e-12,
                "{} {}",
                gt[i],
                est[j]
            );
            // The nearest ground-truth stamp by brute force (first one on a tie).
            let nearest = (0..gt.len())
                .min_by(|&a, &b| (gt[a] - est[j]).abs().total_cmp(&(gt[b] - est[j]).abs()))
                .unwrap();
            assert_eq!(i, nearest);
        }
        // Estimate indices come in order, each once.
        assert!(pairs.windows(2).all(|w| w[0].1 < w[1].1));
        // Swapping the arguments swaps the pairs.
        let swapped = associate(&stamps(&est), &stamps(&gt), EVO_MAX_DIFF_S);
        assert_eq!(
            swapped,
            pairs.iter().map(|&(i, j)| (j, i)).collect::<Vec<_>>()
        );
    }
}
