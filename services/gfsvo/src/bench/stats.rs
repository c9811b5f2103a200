//! Order statistics of per-frame timings.

use serde::Serialize;

/// Median, tail and mean of a set of samples (milliseconds in the benchmarks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// 50th percentile.
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest sample.
    pub max: f64,
    /// Arithmetic mean.
    pub mean: f64,
    /// Number of samples.
    pub count: usize,
}

impl Summary {
    /// Summarises `samples` (reordered in place). Empty input gives all zeros.
    pub fn of(samples: &mut [f64]) -> Self {
        if samples.is_empty() {
            return Self::default();
        }
        samples.sort_by(f64::total_cmp);
        let n = samples.len();
        // Nearest-rank percentile: the smallest sample with at least q of the data at or below it.
        let rank = |q: f64| samples[((q * n as f64).ceil() as usize).clamp(1, n) - 1];
        Self {
            median: if n % 2 == 1 {
                samples[n / 2]
            } else {
                0.5 * (samples[n / 2 - 1] + samples[n / 2])
            },
            p90: rank(0.90),
            p99: rank(0.99),
            max: samples[n - 1],
            mean: samples.iter().sum::<f64>() / n as f64,
            count: n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_of_one_to_hundred() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Summary::of(&mut v);
        assert_eq!(
            (s.median, s.p90, s.p99, s.max, s.mean),
            (50.5, 90.0, 99.0, 100.0, 50.5)
        );
        assert_eq!(Summary::of(&mut []), Summary::default());
    }
}
