//! Line matching by LBD descriptors: Hamming distance, best / second-best ratio test,
//! angle and length-ratio gates, optional per-query candidate lists (the tracker's grid
//! candidates, section III-C "Grid-based Tracking") and a mutual check.

use crate::lbd::{LbdDescriptor, hamming};
use crate::{DetectedLine, Segment};
use serde::{Deserialize, Serialize};

/// Parameters of the matcher.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineMatchConfig {
    /// Largest accepted Hamming distance (of 256 bits). Default 80, about where
    /// descriptors of unrelated lines start (they differ in ~128 bits).
    pub max_distance: u32,
    /// Best distance must be below `ratio` x second best. Default 0.8 (Lowe's ratio).
    pub ratio: f32,
    /// Largest angle between the two undirected lines, degrees. Default 30, generous
    /// for frame-to-frame rotation about the optical axis.
    pub max_angle_deg: f32,
    /// Smallest length ratio shorter / longer. Default 0.4 (a line may be broken or
    /// occluded differently in the two frames).
    pub min_length_ratio: f32,
    /// Keep a match only when each line is the other's best. Default true.
    pub mutual: bool,
}

impl Default for LineMatchConfig {
    fn default() -> Self {
        Self {
            max_distance: 80,
            ratio: 0.8,
            max_angle_deg: 30.0,
            min_length_ratio: 0.4,
            mutual: true,
        }
    }
}

/// One accepted match.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineMatch {
    /// Index of the query line.
    pub query: u32,
    /// Index of the train line.
    pub train: u32,
    /// Hamming distance.
    pub distance: u32,
}

/// Borrowed lines of one frame: lines and descriptors, index-aligned (see
/// [`crate::LineFeatures::as_set`]).
#[derive(Clone, Copy, Debug)]
pub struct LineSet<'a> {
    /// Segments, pixels.
    pub lines: &'a [DetectedLine],
    /// One descriptor per segment.
    pub descriptors: &'a [LbdDescriptor],
}

/// Candidate train lines per query line, as compressed rows (filled by the caller, e.g.
/// from [`crate::grid::LineGrid::candidates`]).
#[derive(Clone, Debug, Default)]
pub struct CandidateLists {
    offsets: Vec<u32>,
    indices: Vec<u32>,
}

impl CandidateLists {
    /// Empties the lists, keeping their storage.
    pub fn clear(&mut self) {
        self.offsets.clear();
        self.indices.clear();
    }

    /// Appends the candidate list of the next query line.
    pub fn push(&mut self, candidates: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.indices.extend_from_slice(candidates);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Number of query lines with a list.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when no list was pushed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The candidates of query line `query` (empty beyond the pushed lists).
    pub fn of(&self, query: usize) -> &[u32] {
        match (self.offsets.get(query), self.offsets.get(query + 1)) {
            (Some(&a), Some(&b)) => &self.indices[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// Matches lines of two frames; owns the reverse-best scratch.
#[derive(Clone, Debug, Default)]
pub struct LineMatcher {
    config: LineMatchConfig,
    /// Per train line: (best distance, query) over the gated pairs.
    reverse: Vec<(u32, u32)>,
    /// Per query line: (best train, best distance) if it passed the ratio test.
    forward: Vec<Option<(u32, u32)>>,
    /// `0..n` train indices, the candidate list of the exhaustive mode.
    every: Vec<u32>,
}

impl LineMatcher {
    /// A matcher with `config`.
    pub fn new(config: LineMatchConfig) -> Self {
        Self {
            config,
            ..Self::default()
        }
    }

    /// The configuration.
    pub fn config(&self) -> &LineMatchConfig {
        &self.config
    }

    /// Writes into `out` (cleared) the matches from `query` to `train`, in query order.
    /// With `candidates`, query line `i` is compared only with `candidates.of(i)`;
    /// without, with every train line. Out-of-range candidate indices are ignored.
    pub fn match_lines(
        &mut self,
        query: LineSet<'_>,
        train: LineSet<'_>,
        candidates: Option<&CandidateLists>,
        out: &mut Vec<LineMatch>,
    ) {
        out.clear();
        let Self {
            config,
            reverse,
            forward,
            every,
        } = self;
        let nq = query.lines.len().min(query.descriptors.len());
        let nt = train.lines.len().min(train.descriptors.len());
        reverse.clear();
        reverse.resize(nt, (u32::MAX, u32::MAX));
        forward.clear();
        forward.resize(nq, None);
        every.clear();
        if candidates.is_none() {
            every.extend(0..nt as u32);
        }
        let cos_max = config.max_angle_deg.to_radians().cos();
        for (q, slot) in forward.iter_mut().enumerate() {
            let list = candidates.map_or(every.as_slice(), |c| c.of(q));
            let (qs, qd) = (&query.lines[q].segment, &query.descriptors[q]);
            let (qdir, qlen) = direction(qs);
            let (mut best, mut second, mut best_t) = (u32::MAX, u32::MAX, u32::MAX);
            for &t in list {
                let ti = t as usize;
                if ti >= nt {
                    continue;
                }
                let (tdir, tlen) = direction(&train.lines[ti].segment);
                // Undirected lines: |cos| of the angle between them.
                let cos = (qdir[0] * tdir[0] + qdir[1] * tdir[1]).abs();
                if cos < cos_max || qlen.min(tlen) < config.min_length_ratio * qlen.max(tlen) {
                    continue;
                }
                let d = hamming(qd, &train.descriptors[ti]);
                if d < reverse[ti].0 {
                    reverse[ti] = (d, q as u32);
                }
                if d < best {
                    second = best;
                    best = d;
                    best_t = t;
                } else if d < second {
                    second = d;
                }
            }
            let passes_ratio = second == u32::MAX || (best as f32) < config.ratio * second as f32;
            if best <= config.max_distance && passes_ratio {
                *slot = Some((best_t, best));
            }
        }
        for (q, f) in forward.iter().enumerate() {
            if let Some((t, d)) = *f {
                if config.mutual && reverse[t as usize].1 != q as u32 {
                    continue;
                }
                out.push(LineMatch {
                    query: q as u32,
                    train: t,
                    distance: d,
                });
            }
        }
    }
}

/// Unit direction and length of a segment (zero direction when degenerate).
fn direction(s: &Segment) -> ([f32; 2], f32) {
    let (du, dv) = (s.end[0] - s.start[0], s.end[1] - s.start[1]);
    let len = du.hypot(dv);
    if len > f32::EPSILON {
        ([du / len, dv / len], len)
    } else {
        ([0.0, 0.0], 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{H, Rng, Scene, W, Warp, render, sobel};
    use crate::grid::{GridConfig, LineGrid};
    use crate::lbd::{LbdConfig, LbdExtractor};

    #[test]
    fn lbd_matches_a_rotated_scaled_shifted_frame() {
        let mut rng = Rng(42);
        let scene = Scene::new(&mut rng);
        let identity = Warp {
            angle: 0.0,
            scale: 1.0,
            t: [0.0, 0.0],
        };
        let warp = Warp {
            angle: 6f32.to_radians(),
            scale: 1.08,
            t: [12.0, -8.0],
        };
        let inside = |p: [f32; 2]| {
            p[0] > 5.0 && p[1] > 5.0 && p[0] < W as f32 - 6.0 && p[1] < H as f32 - 6.0
        };
        let (mut first, mut second) = (Vec::new(), Vec::new());
        for s in scene.segments() {
            let (a, b) = (warp.apply(s.start), warp.apply(s.end));
            if inside(a) && inside(b) {
                first.push(s);
                second.push(Segment { start: a, end: b });
            }
        }
        let (gx1, gy1) = sobel(&render(&scene, &identity, &mut rng));
        let (gx2, gy2) = sobel(&render(&scene, &warp, &mut rng));
        let mut lbd = LbdExtractor::new(LbdConfig::default());
        let (mut d1, mut d2) = (Vec::new(), Vec::new());
        lbd.describe(&gx1.view(), &gy1.view(), &first, &mut d1);
        lbd.describe(&gx2.view(), &gy2.view(), &second, &mut d2);
        let (l1, l2) = (detected(&first), detected(&second));
        let q = LineSet {
            lines: &l1,
            descriptors: &d1,
        };
        let t = LineSet {
            lines: &l2,
            descriptors: &d2,
        };
        let mut matcher = LineMatcher::new(LineMatchConfig::default());
        let mut matches = Vec::new();
        matcher.match_lines(q, t, None, &mut matches);
        let correct = matches.iter().filter(|m| m.query == m.train).count();
        let n = first.len();
        println!(
            "exhaustive: {} lines, {} accepted, {correct} correct",
            n,
            matches.len()
        );
        assert!(n >= 120, "{n} lines in view");
        assert!(correct as f32 >= 0.9 * matches.len() as f32);
        assert!(matches.len() as f32 >= 0.5 * n as f32);

        // Grid candidates around each query line's position (as the tracker does with a
        // motion prediction, here the identity: the 12 px shift and the rotation must
        // stay within one cell of the grid).
        let mut grid = LineGrid::new(&GridConfig::default());
        grid.build(W, H, &second);
        let (mut lists, mut cells, mut cand) = (CandidateLists::default(), Vec::new(), Vec::new());
        for s in &first {
            grid.candidates(s, 1, false, &mut cells, &mut cand);
            lists.push(&cand);
        }
        matcher.match_lines(q, t, Some(&lists), &mut matches);
        let correct_grid = matches.iter().filter(|m| m.query == m.train).count();
        println!("grid: {} accepted, {correct_grid} correct", matches.len());
        assert!(correct_grid as f32 >= 0.9 * matches.len() as f32);
        assert!(correct_grid as f32 >= 0.5 * n as f32);
    }

    fn detected(segments: &[Segment]) -> Vec<DetectedLine> {
        segments
            .iter()
            .map(|&segment| DetectedLine {
                segment,
                mean_gradient: 1.0,
            })
            .collect()
    }

    #[test]
    fn gates_and_empty_inputs() {
        let s = detected(&[Segment::new(0.0, 0.0, 100.0, 0.0)]);
        let d = [[0u64; 4]];
        let rotated = detected(&[Segment::new(0.0, 0.0, 0.0, 100.0)]);
        let short = detected(&[Segment::new(0.0, 0.0, 20.0, 0.0)]);
        let mut m = LineMatcher::new(LineMatchConfig::default());
        let mut out = Vec::new();
        m.match_lines(
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            None,
            &mut out,
        );
        assert_eq!(
            out,
            vec![LineMatch {
                query: 0,
                train: 0,
                distance: 0
            }]
        );
        m.match_lines(
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            LineSet {
                lines: &rotated,
                descriptors: &d,
            },
            None,
            &mut out,
        );
        assert!(out.is_empty(), "90 degrees apart");
        m.match_lines(
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            LineSet {
                lines: &short,
                descriptors: &d,
            },
            None,
            &mut out,
        );
        assert!(out.is_empty(), "length ratio 0.2");
        m.match_lines(
            LineSet {
                lines: &[],
                descriptors: &[],
            },
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            None,
            &mut out,
        );
        assert!(out.is_empty());
        let mut lists = CandidateLists::default();
        lists.push(&[7, 0]);
        m.match_lines(
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            LineSet {
                lines: &s,
                descriptors: &d,
            },
            Some(&lists),
            &mut out,
        );
        assert_eq!(out.len(), 1);
    }
}
