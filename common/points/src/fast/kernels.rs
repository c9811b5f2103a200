//! The per-block FAST kernels: branch-free loops over `L` lanes that the compiler
//! vectorises (16 lanes SSE2, 32 lanes AVX2), and the scalar reference test.

/// Scores of one row (`out.len() >= L` pixels from flat index `row_base`) in blocks of
/// `L`; a tail of at most 16 pixels is one 16-lane block, a longer one an `L` block,
/// overlapping the previous block (same scores, hits pushed once). Hits are pushed as
/// `(column in the row, 0)`.
#[inline(always)]
pub(super) fn row_blocks<const L: usize>(
    data: &[u8],
    row_base: isize,
    offsets: &[isize; 16],
    threshold: u8,
    out: &mut [u8],
    hits: &mut Vec<(u32, u32)>,
) {
    let n = out.len();
    let full = n / L * L;
    let mut push = |start: usize, mut found: u64| {
        while found != 0 {
            hits.push(((start + found.trailing_zeros() as usize) as u32, 0));
            found &= found - 1;
        }
    };
    for start in (0..full).step_by(L) {
        let lanes: &mut [u8; L] = (&mut out[start..start + L]).try_into().expect("L lanes");
        push(
            start,
            block_scores(data, row_base + start as isize, offsets, threshold, lanes),
        );
    }
    let tail = n - full;
    if tail == 0 {
        return;
    }
    let fresh = !0u64;
    if L > 16 && tail <= 16 {
        let start = n - 16;
        let lanes: &mut [u8; 16] = (&mut out[start..n]).try_into().expect("16 lanes");
        let found = block_scores(data, row_base + start as isize, offsets, threshold, lanes);
        push(start, found & (fresh << (16 - tail)));
    } else {
        let start = n - L;
        let lanes: &mut [u8; L] = (&mut out[start..n]).try_into().expect("L lanes");
        let found = block_scores(data, row_base + start as isize, offsets, threshold, lanes);
        push(start, found & (fresh << (L - tail)));
    }
}

/// `L` pixels from flat index `at`, as signed bytes (`x ^ 0x80`) so that unsigned
/// order becomes one signed compare instruction.
#[inline(always)]
fn load_signed<const L: usize>(data: &[u8], at: isize) -> [i8; L] {
    let at = at as usize;
    let src: &[u8; L] = data[at..at + L].try_into().expect("L bytes");
    let mut v = [0i8; L];
    for i in 0..L {
        v[i] = (src[i] ^ 0x80) as i8;
    }
    v
}

/// Lane mask: -1 (all bits) where `a > b`, else 0.
#[inline(always)]
fn greater<const L: usize>(a: &[i8; L], b: &[i8; L]) -> [i8; L] {
    let mut m = [0i8; L];
    for i in 0..L {
        m[i] = -i8::from(a[i] > b[i]);
    }
    m
}

/// FAST test of the `L <= 64` pixels starting at flat index `base`: scores into `out`,
/// and the bit mask of the corners (bit i = lane i) as result.
///
/// Branch-free over the lanes so that it auto-vectorises. Two pre-tests reject most
/// blocks: a 9-arc covers two adjacent compass points (ring 0, 4, 8, 12), and four
/// consecutive even points. The full test then needs only the even starts: a 9-arc
/// starting at `2e` is the 8-run `2e..2e+7` plus `2e+8`, one starting at `2e-1` is the
/// same 8-run plus `2e-1`; the 8-runs at even starts come from three rounds of pairwise
/// ANDs.
#[inline(always)]
fn block_scores<const L: usize>(
    data: &[u8],
    base: isize,
    offsets: &[isize; 16],
    t: u8,
    out: &mut [u8; L],
) -> u64 {
    let centre: &[u8; L] = data[base as usize..base as usize + L]
        .try_into()
        .expect("L bytes");
    let mut hi = [0i8; L];
    let mut lo = [0i8; L];
    for i in 0..L {
        hi[i] = (centre[i].saturating_add(t) ^ 0x80) as i8;
        lo[i] = (centre[i].saturating_sub(t) ^ 0x80) as i8;
    }
    // Masks per ring point: brighter than centre + t, darker than centre - t.
    let mut bright = [[0i8; L]; 16];
    let mut dark = [[0i8; L]; 16];
    for k in [0, 4, 8, 12] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let mut any = [0i8; L];
    for m in [&bright, &dark] {
        for i in 0..L {
            any[i] |= (m[0][i] | m[8][i]) & (m[4][i] | m[12][i]);
        }
    }
    if any.iter().fold(0, |a, &b| a | b) == 0 {
        out.fill(0);
        return 0;
    }
    for k in [2, 6, 10, 14] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let mut any = [0i8; L];
    for m in [&bright, &dark] {
        let mut pair = [[0i8; L]; 8];
        for e in 0..8 {
            for i in 0..L {
                pair[e][i] = m[2 * e][i] & m[(2 * e + 2) % 16][i];
            }
        }
        for e in 0..8 {
            for i in 0..L {
                any[i] |= pair[e][i] & pair[(e + 1) % 8][i];
            }
        }
    }
    if any.iter().fold(0, |a, &b| a | b) == 0 {
        out.fill(0);
        return 0;
    }
    for k in [1, 3, 5, 7, 9, 11, 13, 15] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let corner_b = arc9(&bright);
    let corner_d = arc9(&dark);
    out.fill(0);
    let mut corners = 0u64;
    for i in 0..L {
        corners |= u64::from((corner_b[i] | corner_d[i]) != 0) << i;
    }
    // Corners are rare (about 1 pixel in 100 at threshold 20): score them one by one.
    let mut rest = corners;
    while rest != 0 {
        let i = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let at = base + i as isize;
        let mut ring = [0u8; 16];
        for (p, &off) in ring.iter_mut().zip(offsets) {
            *p = data[(at + off) as usize];
        }
        out[i] = arc_score(&ring, centre[i], corner_b[i] != 0);
    }
    corners
}

/// Masks of the ring pixels at `at`: brighter than `hi`, darker than `lo`.
#[inline(always)]
fn classify<const L: usize>(
    data: &[u8],
    at: isize,
    hi: &[i8; L],
    lo: &[i8; L],
    bright: &mut [i8; L],
    dark: &mut [i8; L],
) {
    let p = load_signed::<L>(data, at);
    *bright = greater(&p, hi);
    *dark = greater(lo, &p);
}

/// Lane mask of "the 16 ring masks `m` hold 9 contiguous set points".
#[inline(always)]
fn arc9<const L: usize>(m: &[[i8; L]; 16]) -> [i8; L] {
    let mut run = [[0i8; L]; 8];
    for e in 0..8 {
        for i in 0..L {
            run[e][i] = m[2 * e][i] & m[2 * e + 1][i];
        }
    }
    let mut run4 = [[0i8; L]; 8];
    for e in 0..8 {
        for i in 0..L {
            run4[e][i] = run[e][i] & run[(e + 1) % 8][i];
        }
    }
    let mut out = [0i8; L];
    for e in 0..8 {
        for i in 0..L {
            let run8 = run4[e][i] & run4[(e + 2) % 8][i];
            out[i] |= run8 & (m[(2 * e + 8) % 16][i] | m[(2 * e + 15) % 16][i]);
        }
    }
    out
}

/// Full ring test of the pixel at flat index `base`; its score when it is a corner at
/// `t`, else 0.
#[inline]
pub(super) fn full_test(data: &[u8], base: isize, offsets: &[isize; 16], t: u8) -> u8 {
    let c = data[base as usize];
    let hi = c.saturating_add(t);
    let lo = c.saturating_sub(t);
    let mut ring = [0u8; 16];
    let mut bright = 0u32;
    let mut dark = 0u32;
    for (k, (&off, p)) in offsets.iter().zip(ring.iter_mut()).enumerate() {
        *p = data[(base + off) as usize];
        bright |= u32::from(*p > hi) << k;
        dark |= u32::from(*p < lo) << k;
    }
    if has_arc9(bright) {
        arc_score(&ring, c, true)
    } else if has_arc9(dark) {
        arc_score(&ring, c, false)
    } else {
        0
    }
}

/// True when the circular 16-bit mask `m` has 9 contiguous set bits.
#[inline]
pub(super) fn has_arc9(m: u32) -> bool {
    let x = m | (m << 16);
    let x2 = x & (x >> 1);
    let x4 = x2 & (x2 >> 2);
    let x8 = x4 & (x4 >> 4);
    x8 & (x >> 8) != 0
}

/// `max over the 16 arcs of 9 of (min over the arc of the signed difference)`, the
/// largest threshold at which the corner holds on the `bright` (or dark) side.
#[inline]
pub(super) fn arc_score(ring: &[u8; 16], c: u8, bright: bool) -> u8 {
    let mut d = [0i16; 24];
    for (k, v) in d.iter_mut().enumerate() {
        let p = i16::from(ring[k % 16]);
        *v = if bright {
            p - i16::from(c)
        } else {
            i16::from(c) - p
        };
    }
    let mut m2 = [0i16; 23];
    for k in 0..23 {
        m2[k] = d[k].min(d[k + 1]);
    }
    let mut m4 = [0i16; 21];
    for k in 0..21 {
        m4[k] = m2[k].min(m2[k + 2]);
    }
    let mut best = 0i16;
    for k in 0..16 {
        best = best.max(m4[k].min(m4[k + 4]).min(d[k + 8]));
    }
    best.clamp(0, 255) as u8
}
