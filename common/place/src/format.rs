//! The on-disk form of a vocabulary: a little-endian layout, versioned, with its length
//! and a checksum verified before anything is trusted.
//!
//! ```text
//! magic        8 bytes  "GFSVOCAB"
//! version      u32      1
//! branching    u32      k
//! levels       u32      L
//! nodes        u32      the root included
//! words        u32      leaves
//! text_len     u32      then text_len bytes of UTF-8: how it was made
//! child_count  u8  x nodes          breadth first, 0 for a leaf
//! centres      32 bytes x (nodes-1) nodes 1.. (the root has none), 4 LE u64 each
//! weights      f32 x words          idf, leaf order
//! checksum     u64                  FNV-1a 64 of every byte before it
//! ```

use crate::error::{VocabularyFileError, VocabularyFormatError};
use crate::vocabulary::Vocabulary;
use gfs_core::descriptor::Descriptor;
use gfs_core::le_bytes::LeReader;
use std::path::Path;

const MAGIC: &[u8; 8] = b"GFSVOCAB";
/// Version of the layout written by [`Vocabulary::to_bytes`].
pub const FORMAT_VERSION: u32 = 1;
/// Bytes of the fixed header (magic + six u32).
const HEADER: usize = 8 + 6 * 4;
/// Longest description accepted (a paragraph, not a file).
const MAX_TEXT: usize = 1 << 16;

/// FNV-1a, 64 bits: a tiny checksum that catches truncation and flipped bytes.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Vocabulary {
    /// The vocabulary in the on-disk layout (see the module doc).
    pub fn to_bytes(&self) -> Vec<u8> {
        let text = self.description.as_bytes();
        let mut out = Vec::with_capacity(
            HEADER + 4 + text.len() + self.num_nodes() * 33 + 4 * self.num_words() + 8,
        );
        out.extend_from_slice(MAGIC);
        for v in [
            FORMAT_VERSION,
            self.branching,
            self.levels,
            self.num_nodes() as u32,
            self.num_words() as u32,
            text.len() as u32,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(text);
        out.extend_from_slice(&self.child_count);
        for centre in &self.centres[1..] {
            for word in centre {
                out.extend_from_slice(&word.to_le_bytes());
            }
        }
        for w in &self.weights {
            out.extend_from_slice(&w.to_le_bytes());
        }
        let checksum = fnv1a(&out);
        out.extend_from_slice(&checksum.to_le_bytes());
        out
    }

    /// Parses the on-disk layout, checking the magic, version, length, checksum and
    /// that the counts describe a breadth-first tree.
    ///
    /// # Errors
    /// [`VocabularyFormatError`] saying what is wrong; never panics on any bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, VocabularyFormatError> {
        let len = bytes.len();
        if len < HEADER + 8 {
            return Err(VocabularyFormatError::Truncated {
                len,
                need: HEADER + 8,
            });
        }
        if &bytes[..8] != MAGIC {
            return Err(VocabularyFormatError::BadMagic);
        }
        let mut r = LeReader::new(bytes, 8);
        let version = r.u32();
        if version != FORMAT_VERSION {
            return Err(VocabularyFormatError::Version(version));
        }
        let (branching, levels) = (r.u32(), r.u32());
        let (nodes, words, text_len) = (r.u32() as usize, r.u32() as usize, r.u32() as usize);
        let inconsistent = |s: String| VocabularyFormatError::Inconsistent(s);
        if nodes == 0 || text_len > MAX_TEXT {
            return Err(inconsistent(format!(
                "{nodes} nodes, {text_len} bytes of text"
            )));
        }
        // u64 arithmetic: the announced counts may be absurd.
        let need = (HEADER + text_len) as u64 + 33 * nodes as u64 - 32 + 4 * words as u64 + 8;
        if (len as u64) < need {
            return Err(VocabularyFormatError::Truncated {
                len,
                need: need as usize,
            });
        }
        if len as u64 > need {
            return Err(VocabularyFormatError::TrailingBytes {
                len,
                expected: need as usize,
            });
        }
        let stored = u64::from_le_bytes(last_8(bytes));
        let computed = fnv1a(&bytes[..len - 8]);
        if stored != computed {
            return Err(VocabularyFormatError::Checksum { stored, computed });
        }
        let description = String::from_utf8(r.slice(text_len).to_vec())
            .map_err(|_| inconsistent("description is not UTF-8".into()))?;
        let child_count = r.slice(nodes).to_vec();
        let mut centres: Vec<Descriptor> = Vec::with_capacity(nodes);
        centres.push([0; 4]);
        for _ in 1..nodes {
            centres.push(std::array::from_fn(|_| u64::from_le_bytes(r.take())));
        }
        let weights: Vec<f32> = (0..words).map(|_| f32::from_le_bytes(r.take())).collect();
        check_tree(branching, levels, &child_count, words)?;
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return Err(inconsistent(
                "a word weight is negative or not finite".into(),
            ));
        }
        Ok(Vocabulary::assemble(
            branching,
            levels,
            child_count,
            centres,
            weights,
            description,
        ))
    }

    /// Writes [`Self::to_bytes`] to `path`.
    ///
    /// # Errors
    /// [`VocabularyFileError::Io`] naming the file.
    pub fn save(&self, path: &Path) -> Result<(), VocabularyFileError> {
        std::fs::write(path, self.to_bytes()).map_err(|source| VocabularyFileError::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// Reads a vocabulary written by [`Self::save`].
    ///
    /// # Errors
    /// [`VocabularyFileError`] naming the file: unreadable, or bytes that are not a
    /// vocabulary (truncated, corrupted, another version).
    pub fn load(path: &Path) -> Result<Self, VocabularyFileError> {
        let bytes = std::fs::read(path).map_err(|source| VocabularyFileError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::from_bytes(&bytes).map_err(|source| VocabularyFileError::Format {
            path: path.to_owned(),
            source,
        })
    }
}

/// The last 8 bytes (the length was checked).
fn last_8(bytes: &[u8]) -> [u8; 8] {
    let mut out = [0; 8];
    out.copy_from_slice(&bytes[bytes.len() - 8..]);
    out
}

/// Checks that breadth-first child counts form a tree of the announced shape: every
/// count at most `branching`, the children of all nodes exactly nodes 1.., every node
/// at depth at most `levels`, and as many leaves as words.
fn check_tree(
    branching: u32,
    levels: u32,
    child_count: &[u8],
    words: usize,
) -> Result<(), VocabularyFormatError> {
    let fail = |s: String| Err(VocabularyFormatError::Inconsistent(s));
    if !(2..=255).contains(&branching) || !(1..=8).contains(&levels) {
        return fail(format!("branching {branching}, levels {levels}"));
    }
    let nodes = child_count.len();
    let mut depth = vec![0u32; nodes];
    let mut next = 1usize;
    for node in 0..nodes {
        let count = usize::from(child_count[node]);
        if count as u32 > branching {
            return fail(format!(
                "node {node} has {count} children, branching {branching}"
            ));
        }
        if count > 0 && depth[node] >= levels {
            return fail(format!("node {node} has children below level {levels}"));
        }
        if next + count > nodes {
            return fail(format!("node {node}'s children run past the {nodes} nodes"));
        }
        for child in next..next + count {
            depth[child] = depth[node] + 1;
        }
        next += count;
        if next <= node + 1 && node + 1 < nodes {
            return fail(format!("node {} has no parent", node + 1));
        }
    }
    if next != nodes {
        return fail(format!("{next} nodes reached, {nodes} stored"));
    }
    let leaves = child_count.iter().filter(|&&c| c == 0).count();
    if leaves != words {
        return fail(format!("{leaves} leaves, {words} word weights"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::clustered;
    use crate::train::VocabularyConfig;

    fn small() -> Vocabulary {
        let (_, d) = clustered(12, 20, 30, 4);
        let images: Vec<Vec<Descriptor>> = d.chunks(40).map(<[_]>::to_vec).collect();
        let config = VocabularyConfig {
            branching: 3,
            levels: 2,
            seed: 2,
        };
        Vocabulary::train(&images, &config, "clustered test data, seed 4").expect("valid")
    }

    #[test]
    fn round_trip_is_exact() {
        let v = small();
        let bytes = v.to_bytes();
        assert_eq!(
            bytes.len(),
            8 + 24 + 27 + 33 * v.num_nodes() - 32 + 4 * v.num_words() + 8
        );
        assert_eq!(Vocabulary::from_bytes(&bytes), Ok(v.clone()));
        let path = std::env::temp_dir().join(format!("gfs-place-{}.bin", std::process::id()));
        v.save(&path).expect("writable temp dir");
        let back = Vocabulary::load(&path).expect("just written");
        std::fs::remove_file(&path).ok();
        assert_eq!(back, v);
        assert_eq!(back.description(), "clustered test data, seed 4");
    }

    #[test]
    fn truncated_corrupted_and_foreign_bytes_are_errors() {
        let bytes = small().to_bytes();
        for cut in [0, 10, 40, bytes.len() / 2, bytes.len() - 1] {
            assert!(
                matches!(
                    Vocabulary::from_bytes(&bytes[..cut]),
                    Err(VocabularyFormatError::Truncated { .. })
                ),
                "cut at {cut}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(matches!(
            Vocabulary::from_bytes(&longer),
            Err(VocabularyFormatError::TrailingBytes { .. })
        ));
        for at in [60, bytes.len() / 2, bytes.len() - 3] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            assert!(
                matches!(
                    Vocabulary::from_bytes(&bad),
                    Err(VocabularyFormatError::Checksum { .. })
                ),
                "flip at {at}"
            );
        }
        let mut magic = bytes.clone();
        magic[0] = b'X';
        assert_eq!(
            Vocabulary::from_bytes(&magic),
            Err(VocabularyFormatError::BadMagic)
        );
        let mut version = bytes.clone();
        version[8] = 9;
        assert_eq!(
            Vocabulary::from_bytes(&version),
            Err(VocabularyFormatError::Version(9))
        );
        // A consistent checksum over an impossible tree: a child count above k.
        let mut tree = bytes.clone();
        tree[HEADER + 27] = 200;
        let n = tree.len() - 8;
        let sum = fnv1a(&tree[..n]).to_le_bytes();
        tree[n..].copy_from_slice(&sum);
        assert!(matches!(
            Vocabulary::from_bytes(&tree),
            Err(VocabularyFormatError::Inconsistent(_))
        ));
        // Huge announced counts: an error, not an allocation.
        let mut huge = bytes.clone();
        huge[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            Vocabulary::from_bytes(&huge),
            Err(VocabularyFormatError::Truncated { .. })
        ));
        let missing = Path::new("/nonexistent/orb.bin");
        let e = Vocabulary::load(missing).expect_err("no such file");
        assert!(e.to_string().contains("/nonexistent/orb.bin"), "{e}");
    }
}
