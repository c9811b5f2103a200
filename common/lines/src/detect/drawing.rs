//! Edge Drawing, EDLines step 4 (Topal & Akinlar, "Edge Drawing", 2012): from every anchor,
//! strongest first, walk along the ridge of the gradient magnitude in both directions,
//! always stepping to the strongest of the three pixels ahead, turning when the pixel's
//! edge orientation changes, and stopping below the gradient threshold or on reaching an
//! existing chain. Each anchor yields one ordered chain of pixels.

use gfs_core::Image;

use super::gradient::{EDGE, HORIZONTAL, NONE, ORIENTATION, VERTICAL};

/// Chains of edge pixels (flat pixel indices `v * width + u`), stored back to back.
#[derive(Debug, Default)]
pub(crate) struct Chains {
    /// All chain pixels.
    pixels: Vec<u32>,
    /// Chain `k` is `pixels[ends[k - 1]..ends[k]]` (with `ends[-1] = 0`).
    ends: Vec<u32>,
    /// Scratch for the backward walk of the current anchor.
    backward: Vec<u32>,
}

impl Chains {
    /// Iterator over the chains, each an ordered slice of pixel indices.
    pub(crate) fn iter(&self) -> impl Iterator<Item = &[u32]> {
        let starts = std::iter::once(0).chain(self.ends.iter().copied());
        starts
            .zip(self.ends.iter().copied())
            .map(|(a, b)| &self.pixels[a as usize..b as usize])
    }
}

/// One routing step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    Left,
    Right,
    Up,
    Down,
}

/// Routes edges from `anchors` (see [`super::anchors::find_anchors`]) and stores the
/// chains of at least `min_length` pixels. Marks chain pixels with [`EDGE`] in `state`.
pub(crate) fn draw_edges(
    magnitude: &Image<u16>,
    state: &mut Image<u8>,
    anchors: &[u64],
    min_length: usize,
    chains: &mut Chains,
) {
    chains.pixels.clear();
    chains.ends.clear();
    let w = magnitude.width();
    let mag = magnitude.as_slice();
    let st = state.as_mut_slice();
    for &anchor in anchors {
        let a = (anchor & 0xffff_ffff) as usize;
        if st[a] & EDGE != 0 {
            continue;
        }
        st[a] |= EDGE;
        let (back, ahead) = if st[a] & ORIENTATION == HORIZONTAL {
            (Step::Left, Step::Right)
        } else {
            (Step::Up, Step::Down)
        };
        chains.backward.clear();
        walk(a, back, w, mag, st, &mut chains.backward);
        let start = chains.pixels.len();
        chains.pixels.extend(chains.backward.iter().rev());
        chains.pixels.push(a as u32);
        walk(a, ahead, w, mag, st, &mut chains.pixels);
        if chains.pixels.len() - start >= min_length.max(2) {
            chains.ends.push(chains.pixels.len() as u32);
        } else {
            chains.pixels.truncate(start);
        }
    }
}

/// The three pixels ahead of `i` for `step` (straight ahead in the middle).
#[inline]
fn ahead(i: usize, step: Step, w: usize) -> [usize; 3] {
    match step {
        Step::Left => [i - w - 1, i - 1, i + w - 1],
        Step::Right => [i - w + 1, i + 1, i + w + 1],
        Step::Up => [i - w - 1, i - w, i - w + 1],
        Step::Down => [i + w - 1, i + w, i + w + 1],
    }
}

/// The two pixels beside `i` across `step`.
#[inline]
fn beside(i: usize, step: Step, w: usize) -> [usize; 2] {
    match step {
        Step::Left | Step::Right => [i - w, i + w],
        Step::Up | Step::Down => [i - 1, i + 1],
    }
}

/// The strongest free edge candidate among `candidates`, with its magnitude.
#[inline]
fn strongest(candidates: [usize; 3], mag: &[u16], st: &[u8]) -> Option<(usize, u16)> {
    let mut best: Option<(usize, u16)> = None;
    // Straight ahead first so that it wins ties.
    for c in [candidates[1], candidates[0], candidates[2]] {
        let s = st[c];
        if s & EDGE == 0 && s & ORIENTATION != NONE && best.is_none_or(|(_, m)| mag[c] > m) {
            best = Some((c, mag[c]));
        }
    }
    best
}

/// Walks from `start` (already marked) in direction `step`, pushing and marking every new
/// pixel. Invariant: the current pixel is an edge candidate, hence interior, so all its
/// neighbours are inside the image.
fn walk(start: usize, mut step: Step, w: usize, mag: &[u16], st: &mut [u8], out: &mut Vec<u32>) {
    let mut current = start;
    let mut previous = usize::MAX;
    loop {
        let orientation = st[current] & ORIENTATION;
        let turn = match step {
            Step::Left | Step::Right if orientation == VERTICAL => Some((Step::Up, Step::Down)),
            Step::Up | Step::Down if orientation == HORIZONTAL => Some((Step::Left, Step::Right)),
            _ => None,
        };
        if let Some((a, b)) = turn {
            let ga = strongest(ahead(current, a, w), mag, st).map_or(0, |(_, m)| m);
            let gb = strongest(ahead(current, b, w), mag, st).map_or(0, |(_, m)| m);
            step = if gb > ga { b } else { a };
        }
        // Running alongside an existing chain: stop (ED), it already covers this edge.
        let running_along = beside(current, step, w)
            .iter()
            .any(|&b| b != previous && st[b] & EDGE != 0);
        let candidates = ahead(current, step, w);
        if running_along || st[candidates[1]] & EDGE != 0 {
            break;
        }
        let Some((next, _)) = strongest(candidates, mag, st) else {
            break;
        };
        st[next] |= EDGE;
        out.push(next as u32);
        previous = current;
        current = next;
    }
}
