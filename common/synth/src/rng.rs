//! Keyed random streams and lattice noise for the generator.
//!
//! Every random choice of the generator (textures, trajectory phases, noise) comes from
//! [`SplitMix64`] streams keyed by the sequence seed and by *what* is drawn (frame, row,
//! texture), so that results never depend on thread count or on the order of work.

pub use gfs_core::rng::{SplitMix64, hash, mix};

/// Hash of a 2D lattice point, as a value in [0, 1). One mixer call: texture noise
/// needs decorrelated values, not cryptographic quality, and this is its hot loop.
#[inline]
pub fn lattice(seed: u64, i: i64, j: i64) -> f64 {
    let key = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    (mix(seed ^ key) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// `x.floor()` without the libm call that the baseline x86-64 target makes for it.
#[inline]
pub fn floor(x: f64) -> f64 {
    let i = x as i64 as f64;
    if i > x { i - 1.0 } else { i }
}
