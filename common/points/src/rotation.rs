//! The rotation-consistency check of ORB-SLAM2's matchers: the orientation change of
//! every tentative match is binned, and only matches in the three fullest bins survive
//! (a rigid camera motion rotates all keypoints alike).

/// Histogram of keypoint-orientation differences over a set of tentative matches.
/// Reusable: [`RotationHistogram::clear`] keeps the memory.
#[derive(Clone, Debug)]
pub struct RotationHistogram {
    counts: Vec<u32>,
    /// `(bin, match id)` of every match added.
    entries: Vec<(u16, usize)>,
}

/// Bins of ORB-SLAM2's `HISTO_LENGTH` (12 degrees each).
pub const ROTATION_BINS: usize = 30;

/// A bin below this fraction of the fullest one is not kept (ORB-SLAM2 `ComputeThreeMaxima`).
const MIN_FRACTION_OF_MAX: f32 = 0.1;

impl Default for RotationHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl RotationHistogram {
    /// An empty histogram of [`ROTATION_BINS`] bins over a full turn.
    pub fn new() -> Self {
        Self {
            counts: vec![0; ROTATION_BINS],
            entries: Vec::new(),
        }
    }

    /// Forgets every match.
    pub fn clear(&mut self) {
        self.counts.fill(0);
        self.entries.clear();
    }

    /// Records match `id` whose keypoints have orientations `angle_a` and `angle_b`
    /// (radians). A non-finite difference is recorded in no bin and never kept.
    pub fn add(&mut self, angle_a: f32, angle_b: f32, id: usize) {
        let turn = std::f32::consts::TAU;
        let rot = (angle_a - angle_b).rem_euclid(turn);
        if !rot.is_finite() {
            self.entries.push((u16::MAX, id));
            return;
        }
        let bin = ((rot / turn * ROTATION_BINS as f32).round() as usize) % ROTATION_BINS;
        self.counts[bin] += 1;
        self.entries.push((bin as u16, id));
    }

    /// The (up to three) kept bins: the three fullest, dropping the second and third when
    /// they hold less than a tenth of the fullest.
    pub fn kept_bins(&self) -> [Option<usize>; 3] {
        let mut top: [Option<usize>; 3] = [None; 3];
        for (bin, &c) in self.counts.iter().enumerate() {
            if c == 0 {
                continue;
            }
            let count = |b: Option<usize>| b.map_or(0, |b| self.counts[b]);
            if c > count(top[0]) {
                top = [Some(bin), top[0], top[1]];
            } else if c > count(top[1]) {
                top = [top[0], Some(bin), top[1]];
            } else if c > count(top[2]) {
                top[2] = Some(bin);
            }
        }
        let max = top[0].map_or(0, |b| self.counts[b]) as f32;
        for slot in &mut top[1..] {
            if let Some(b) = *slot
                && (self.counts[b] as f32) < MIN_FRACTION_OF_MAX * max
            {
                *slot = None;
            }
        }
        top
    }

    /// Appends to `out` the ids of the matches outside the kept bins (to be discarded).
    pub fn outliers(&self, out: &mut Vec<usize>) {
        let kept = self.kept_bins();
        for &(bin, id) in &self.entries {
            if !kept.contains(&Some(usize::from(bin))) {
                out.push(id);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_off_the_dominant_rotation_are_outliers() {
        let mut h = RotationHistogram::new();
        // 40 matches rotated by 34..38 degrees, 5 by 100, 3 by 200, 2 by 300.
        for i in 0..40 {
            h.add((36.0f32 + (i % 5) as f32 - 2.0).to_radians(), 0.0, i);
        }
        for i in 40..45 {
            h.add(
                1.0,
                (1.0f32 - 100.0f32.to_radians()).rem_euclid(std::f32::consts::TAU),
                i,
            );
        }
        for i in 45..48 {
            h.add(200.0f32.to_radians(), 0.0, i);
        }
        for i in 48..50 {
            h.add(300.0f32.to_radians(), 0.0, i);
        }
        let kept = h.kept_bins();
        // Bins of 12 degrees, rounded: 34..38 -> 3, 100 -> 8, 200 -> 17, 300 -> 25.
        // Bin 17 (3 matches) is below a tenth of bin 3 (40) and is dropped.
        assert_eq!(kept, [Some(3), Some(8), None]);
        let mut out = Vec::new();
        h.outliers(&mut out);
        assert_eq!(out, vec![45, 46, 47, 48, 49]);
        h.clear();
        assert_eq!(h.kept_bins(), [None; 3]);
    }

    #[test]
    fn small_bins_are_dropped() {
        let mut h = RotationHistogram::new();
        for i in 0..100 {
            h.add(0.0, 0.0, i);
        }
        h.add(1.0, 0.0, 100);
        h.add(f32::NAN, 0.0, 101);
        let mut out = Vec::new();
        h.outliers(&mut out);
        assert_eq!(out, vec![100, 101]);
    }
}
