//! The fixed header in front of a map file's payload: what the file is, which layout,
//! the camera its features were measured with, and the payload's length and checksum.
//! It is checked before a byte of the payload is decoded.
//!
//! ```text
//! magic         8 bytes  "GFSVOMAP"
//! version       u32      FORMAT_VERSION
//! width height  u32 x 2  image size, pixels
//! fx fy cx cy   f64 x 4  undistorted pinhole intrinsics
//! scale_factor  f64      ORB pyramid: scale between levels
//! levels        u32      ORB pyramid: levels
//! payload_len   u64      bytes after the header
//! payload_crc   u32      CRC-32 of the payload
//! header_crc    u32      CRC-32 of every header byte before it
//! ```
//!
//! All little-endian.

use super::{MapCamera, MapFileProblem};
use gfs_core::camera::PinholeCamera;
use gfs_core::le_bytes::LeReader;

const MAGIC: &[u8; 8] = b"GFSVOMAP";
/// The layout [`super::save_map`] writes and [`super::load_map`] reads.
pub const FORMAT_VERSION: u32 = 2;
/// Bytes of the header.
pub const HEADER_BYTES: usize = 8 + 4 + 2 * 4 + 4 * 8 + 8 + 4 + 8 + 4 + 4;

/// A header's fields once its checksum held.
#[derive(Clone, Copy, Debug)]
pub struct Header {
    pub camera: MapCamera,
    pub payload_len: u64,
    pub payload_crc: u32,
}

impl Header {
    /// The header bytes.
    pub fn encode(&self) -> [u8; HEADER_BYTES] {
        let c = &self.camera.camera;
        let mut out = Vec::with_capacity(HEADER_BYTES);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        for size in [c.width, c.height] {
            out.extend_from_slice(&u32::try_from(size).unwrap_or(u32::MAX).to_le_bytes());
        }
        for v in [c.fx, c.fy, c.cx, c.cy, self.camera.scale_factor] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&u32::from(self.camera.levels).to_le_bytes());
        out.extend_from_slice(&self.payload_len.to_le_bytes());
        out.extend_from_slice(&self.payload_crc.to_le_bytes());
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        let mut bytes = [0; HEADER_BYTES];
        bytes.copy_from_slice(&out);
        bytes
    }

    /// Parses the header at the start of `bytes`: the magic, then the version (a
    /// layout this build does not know is refused before its fields are read), then
    /// the header's own checksum.
    pub fn decode(bytes: &[u8]) -> Result<Self, MapFileProblem> {
        if bytes.len() < HEADER_BYTES {
            // A file cut inside the magic is a map file cut short too.
            let n = bytes.len().min(MAGIC.len());
            return Err(if bytes[..n] == MAGIC[..n] {
                MapFileProblem::Truncated {
                    len: bytes.len() as u64,
                    need: HEADER_BYTES as u64,
                }
            } else {
                MapFileProblem::NotAMap
            });
        }
        let mut reader = LeReader::new(bytes, 0);
        if &reader.take::<8>() != MAGIC {
            return Err(MapFileProblem::NotAMap);
        }
        let version = reader.u32();
        if version != FORMAT_VERSION {
            return Err(MapFileProblem::Version(version));
        }
        let (width, height) = (reader.u32(), reader.u32());
        let [fx, fy, cx, cy, scale_factor] = [(); 5].map(|()| reader.f64());
        let levels = reader.u32();
        let payload_len = reader.u64();
        let payload_crc = reader.u32();
        let computed = crc32fast::hash(&bytes[..reader.position()]);
        let stored = reader.u32();
        if stored != computed {
            return Err(MapFileProblem::HeaderChecksum { stored, computed });
        }
        let levels = u8::try_from(levels).map_err(|_| {
            MapFileProblem::Invalid(format!("ORB pyramid of {levels} levels in the header"))
        })?;
        Ok(Self {
            camera: MapCamera {
                camera: PinholeCamera::new(fx, fy, cx, cy, width as usize, height as usize),
                scale_factor,
                levels,
            },
            payload_len,
            payload_crc,
        })
    }
}
