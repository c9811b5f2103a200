//! Map files: the global map kept from one run for the next (`gfsvo run --save-map`,
//! `--load-map`). The file holds the keyframes with their features, the landmarks
//! (points, lines, planes) with their observations (the covisibility graph is derived
//! from them), the retired keyframes, the id counters and loop-correction count, and
//! the world Manhattan axes, behind a [`header`] naming the layout's version and the
//! camera and ORB pyramid the features were measured with.
//!
//! The place-recognition database is not stored: a loaded map's bags of words are
//! computed again from the keyframes' descriptors when the relocaliser and the loop
//! closer first sync with it (`PlaceIndex::sync`), which keeps the file free of a
//! second copy that could disagree with the keyframes.
//!
//! Writing is atomic: the file goes to a temporary name in the same folder, is synced
//! to disk, then renamed over the target, so a crash or a `kill -9` while saving leaves
//! the previous file whole. Reading trusts nothing: the file's size is bounded, the
//! header and the payload are checksummed, bincode decodes with the same bound, and the
//! decoded map's links and numbers are checked ([`crate::map::Map::validate`]) before
//! it is used.

mod header;
mod payload;
#[cfg(test)]
mod tests;

pub use header::FORMAT_VERSION;

use crate::map::Map;
use crate::map::manhattan::WorldManhattan;
use gfs_core::camera::PinholeCamera;
use header::{HEADER_BYTES, Header};
use serde::{Deserialize, Serialize};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Largest payload read (1 GiB: a map of 3000 real keyframes is about 270 MB).
pub const MAX_PAYLOAD_BYTES: usize = 1 << 30;

/// Fixed-width integers, little-endian, bounded allocations (the payload's blobs).
fn codec() -> impl bincode::config::Config {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_little_endian()
        .with_limit::<MAX_PAYLOAD_BYTES>()
}

/// What a map's features were measured with: a run can only use a map made with the
/// same camera (undistorted intrinsics, image size) and ORB pyramid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapCamera {
    /// The undistorted pinhole camera.
    pub camera: PinholeCamera,
    /// Scale between ORB pyramid levels.
    pub scale_factor: f64,
    /// ORB pyramid levels.
    pub levels: u8,
}

impl MapCamera {
    /// True when `other` measures features as this one does (intrinsics within a
    /// billionth, the rest equal).
    pub fn matches(&self, other: &MapCamera) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
        let (a, b) = (&self.camera, &other.camera);
        a.width == b.width
            && a.height == b.height
            && close(a.fx, b.fx)
            && close(a.fy, b.fy)
            && close(a.cx, b.cx)
            && close(a.cy, b.cy)
            && close(self.scale_factor, other.scale_factor)
            && self.levels == other.levels
    }
}

impl std::fmt::Display for MapCamera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = &self.camera;
        write!(
            f,
            "{}x{} fx {} fy {} cx {} cy {}, ORB pyramid {} levels x {}",
            c.width, c.height, c.fx, c.fy, c.cx, c.cy, self.levels, self.scale_factor
        )
    }
}

/// The state a map file keeps: what a mapping half needs to go on from it.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SavedMap {
    /// The global map.
    pub map: Map,
    /// The world Manhattan axes the map's lines and planes are tied to.
    pub manhattan: WorldManhattan,
}

/// What is wrong with a map file's bytes or with writing one.
#[derive(Debug, thiserror::Error)]
pub enum MapFileProblem {
    /// The system refused to read or write it.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Fewer bytes than the header or than the payload it announces.
    #[error("{len} bytes, {need} expected: truncated")]
    Truncated {
        /// Bytes present.
        len: u64,
        /// Bytes the header requires.
        need: u64,
    },
    /// More bytes than the header announces.
    #[error("{len} bytes, the header announces {expected}: trailing bytes")]
    TrailingBytes {
        /// Bytes present.
        len: u64,
        /// Bytes the header announces.
        expected: u64,
    },
    /// Not a map file at all.
    #[error("not a gfsvo map file (no GFSVOMAP magic)")]
    NotAMap,
    /// A layout this build does not read.
    #[error("map format version {0}, this build reads version {FORMAT_VERSION}")]
    Version(u32),
    /// The header's bytes were altered.
    #[error("header checksum {stored:#010x} stored, {computed:#010x} computed: corrupted")]
    HeaderChecksum {
        /// Checksum in the file.
        stored: u32,
        /// Checksum of the header's bytes.
        computed: u32,
    },
    /// The payload's bytes were altered.
    #[error("payload checksum {stored:#010x} stored, {computed:#010x} computed: corrupted")]
    Checksum {
        /// Checksum in the file.
        stored: u32,
        /// Checksum of the payload's bytes.
        computed: u32,
    },
    /// A payload larger than [`MAX_PAYLOAD_BYTES`].
    #[error("payload of {len} bytes, at most {MAX_PAYLOAD_BYTES} are read")]
    TooLarge {
        /// The payload's length.
        len: u64,
    },
    /// Made with another camera or ORB pyramid than the run's.
    #[error("made with another camera: the map's is {map}, this run's is {run}")]
    OtherCamera {
        /// The map's camera.
        map: Box<MapCamera>,
        /// The run's.
        run: Box<MapCamera>,
    },
    /// The payload does not decode as a map.
    #[error("payload does not decode: {0}")]
    Malformed(#[from] bincode::error::DecodeError),
    /// The map cannot be encoded.
    #[error("cannot encode the map: {0}")]
    Encode(#[from] bincode::error::EncodeError),
    /// The decoded map is inconsistent.
    #[error("invalid map: {0}")]
    Invalid(String),
}

/// A map file could not be written or read; names the file.
#[derive(Debug, thiserror::Error)]
#[error("map file {}: {problem}", path.display())]
pub struct MapFileError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub problem: MapFileProblem,
}

/// The file's bytes: header then payload (the figures of the save benchmark).
#[cfg(test)]
fn encode(
    camera: &MapCamera,
    map: &Map,
    manhattan: &WorldManhattan,
) -> Result<(Header, Vec<u8>), MapFileProblem> {
    let mut payload = Vec::new();
    payload::write_payload(&mut payload, map, manhattan)?;
    let header = Header {
        camera: *camera,
        payload_len: payload.len() as u64,
        payload_crc: crc32fast::hash(&payload),
    };
    Ok((header, payload))
}

/// Counts and checksums the payload on its way to the file.
struct PayloadWriter<W> {
    inner: W,
    crc: crc32fast::Hasher,
    len: u64,
}

impl<W: Write> Write for PayloadWriter<W> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let written = self.inner.write(bytes)?;
        self.crc.update(&bytes[..written]);
        self.len += written as u64;
        Ok(written)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Writes the map file into `file`: a blank header, the payload encoded straight into
/// the file (no copy of a map of hundreds of megabytes in memory), then the header
/// with the payload's length and checksum over the blank one. Returns the bytes.
fn write_file(
    file: std::fs::File,
    camera: &MapCamera,
    map: &Map,
    manhattan: &WorldManhattan,
) -> Result<(std::fs::File, u64), MapFileProblem> {
    let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
    out.write_all(&[0; HEADER_BYTES])?;
    let mut payload = PayloadWriter {
        inner: out,
        crc: crc32fast::Hasher::new(),
        len: 0,
    };
    payload::write_payload(&mut payload, map, manhattan)?;
    let header = Header {
        camera: *camera,
        payload_len: payload.len,
        payload_crc: payload.crc.finalize(),
    };
    let mut file = payload
        .inner
        .into_inner()
        .map_err(std::io::IntoInnerError::into_error)?;
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&header.encode())?;
    Ok((file, HEADER_BYTES as u64 + header.payload_len))
}

/// The map in `bytes` (a whole file) when it is intact, of this version, made with
/// `camera`, and consistent.
fn decode(bytes: &[u8], camera: &MapCamera) -> Result<SavedMap, MapFileProblem> {
    let header = Header::decode(bytes)?;
    if !header.camera.matches(camera) {
        return Err(MapFileProblem::OtherCamera {
            map: Box::new(header.camera),
            run: Box::new(*camera),
        });
    }
    if header.payload_len > MAX_PAYLOAD_BYTES as u64 {
        return Err(MapFileProblem::TooLarge {
            len: header.payload_len,
        });
    }
    let expected = HEADER_BYTES as u64 + header.payload_len;
    let len = bytes.len() as u64;
    if len < expected {
        return Err(MapFileProblem::Truncated {
            len,
            need: expected,
        });
    }
    if len > expected {
        return Err(MapFileProblem::TrailingBytes { len, expected });
    }
    let payload = &bytes[HEADER_BYTES..];
    let computed = crc32fast::hash(payload);
    if computed != header.payload_crc {
        return Err(MapFileProblem::Checksum {
            stored: header.payload_crc,
            computed,
        });
    }
    let (map, manhattan) = payload::read_payload(payload)?;
    let saved = SavedMap { map, manhattan };
    saved
        .map
        .validate(camera.levels)
        .map_err(MapFileProblem::Invalid)?;
    if let Some(axes) = saved.manhattan.axes()
        && !axes.matrix().iter().all(|v| v.is_finite())
    {
        return Err(MapFileProblem::Invalid(
            "the Manhattan axes are not finite".to_owned(),
        ));
    }
    Ok(saved)
}

/// Writes `map` with its Manhattan axes as a map file of features measured by
/// `camera`, atomically: to a temporary file beside `path`, synced, then renamed over
/// it (and the folder synced), so that `path` is at all times the old file or the
/// whole new one. Returns the bytes written.
///
/// # Errors
/// [`MapFileError`] naming `path` when the map cannot be encoded or written; `path` is
/// then as it was and the temporary file is removed.
pub fn save_map(
    path: &Path,
    camera: &MapCamera,
    map: &Map,
    manhattan: &WorldManhattan,
) -> Result<u64, MapFileError> {
    let named = |problem| MapFileError {
        path: path.to_owned(),
        problem,
    };
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| named(MapFileProblem::Invalid("the path names no file".to_owned())))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let write = || -> Result<u64, MapFileProblem> {
        let (file, bytes) = write_file(std::fs::File::create(&tmp)?, camera, map, manhattan)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)?;
        std::fs::File::open(dir)?.sync_all()?;
        Ok(bytes)
    };
    write().map_err(|problem| {
        // The target was not touched (the rename is the last step that changes it).
        let _ = std::fs::remove_file(&tmp);
        named(problem)
    })
}

/// Reads the map file at `path`, which must have been made with `camera`.
///
/// # Errors
/// [`MapFileError`] naming `path` and what is wrong: unreadable, not a map file,
/// another format version, another camera, truncated, larger than the bound, corrupted
/// (checksum), or a map whose links or numbers are inconsistent.
pub fn load_map(path: &Path, camera: &MapCamera) -> Result<SavedMap, MapFileError> {
    let named = |problem| MapFileError {
        path: path.to_owned(),
        problem,
    };
    let file = std::fs::File::open(path).map_err(|e| named(e.into()))?;
    let len = file.metadata().map_err(|e| named(e.into()))?.len();
    let bound = (HEADER_BYTES + MAX_PAYLOAD_BYTES) as u64;
    if len > bound {
        return Err(named(MapFileProblem::TooLarge {
            len: len - HEADER_BYTES as u64,
        }));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(bound + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| named(e.into()))?;
    decode(&bytes, camera).map_err(named)
}
