//! CDR payloads as ROS 2 bags store them: the 4-byte encapsulation header
//! (`00 01 00 00`, CDR little endian) and the message, aligned from after the header.

use byteorder::LittleEndian;
use serde::{Serialize, de::DeserializeOwned};

/// The encapsulation header of a little-endian CDR payload.
pub const CDR_LE_HEADER: [u8; 4] = [0, 1, 0, 0];

/// A payload could not be encoded or decoded.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// Shorter than the encapsulation header.
    #[error("{what}: a CDR payload of {len} bytes has no encapsulation header")]
    NoHeader {
        /// The message type.
        what: &'static str,
        /// Bytes.
        len: usize,
    },
    /// Big-endian or XCDR2 encapsulation.
    #[error(
        "{what}: unsupported CDR encapsulation {header:02x?} (expected little-endian CDR 00 01)"
    )]
    Encapsulation {
        /// The message type.
        what: &'static str,
        /// The first two bytes.
        header: [u8; 2],
    },
    /// The bytes do not hold the message.
    #[error("{what}: {message}")]
    Malformed {
        /// The message type.
        what: &'static str,
        /// What the decoder said.
        message: String,
    },
}

/// Appends `message` with its encapsulation header to `out` (cleared first).
///
/// # Errors
/// [`CdrError::Malformed`] when serde refuses the value (a string with a NUL, ...).
pub fn encode_into<T: Serialize>(
    message: &T,
    what: &'static str,
    out: &mut Vec<u8>,
) -> Result<(), CdrError> {
    out.clear();
    out.extend_from_slice(&CDR_LE_HEADER);
    let body =
        cdr_encoding::to_vec::<T, LittleEndian>(message).map_err(|e| CdrError::Malformed {
            what,
            message: e.to_string(),
        })?;
    out.extend_from_slice(&body);
    Ok(())
}

/// Decodes a payload with its encapsulation header.
///
/// # Errors
/// [`CdrError`] for a short payload, another encapsulation, or bytes that are not a `T`.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], what: &'static str) -> Result<T, CdrError> {
    let (header, body) = bytes.split_first_chunk::<4>().ok_or(CdrError::NoHeader {
        what,
        len: bytes.len(),
    })?;
    if header[..2] != CDR_LE_HEADER[..2] {
        return Err(CdrError::Encapsulation {
            what,
            header: [header[0], header[1]],
        });
    }
    cdr_encoding::from_bytes::<T, LittleEndian>(body)
        .map(|(value, _)| value)
        .map_err(|e| CdrError::Malformed {
            what,
            message: e.to_string(),
        })
}
