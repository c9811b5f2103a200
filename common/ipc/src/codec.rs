//! Variable-size messages (keyframes, local-map snapshots): serde values
//! encoded with bincode 2 into a `[u8]` payload.
//!
//! Decoding never trusts the bytes: the payload length is checked against a limit
//! before decoding, bincode runs with the same limit, every length prefix is bounded by
//! the bytes actually present, and trailing bytes are rejected. A malformed, truncated
//! or oversized payload is a [`CodecError`], never a panic (the subscriber helper logs
//! it and drops the sample).

use bincode::config::{Configuration, Fixint, Limit, LittleEndian};
use serde::Serialize;
use serde::de::DeserializeOwned;
use thiserror::Error;

/// Largest variable-size message in bytes (64 MiB): a local-map snapshot of a few
/// thousand points and lines is a few MB.
pub const MAX_VARIABLE_MESSAGE_BYTES: usize = 64 << 20;

/// Fixed-width little-endian integers: the encoded size of a message depends only on its
/// shape, not on its values, which keeps the shared-memory segment size stable.
type Codec = Configuration<LittleEndian, Fixint, Limit<MAX_VARIABLE_MESSAGE_BYTES>>;

fn codec() -> Codec {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_limit::<MAX_VARIABLE_MESSAGE_BYTES>()
}

/// A variable-size message could not be encoded or decoded.
#[derive(Debug, Error)]
pub enum CodecError {
    /// The payload is longer than the limit.
    #[error("message of {len} bytes exceeds the limit of {max} bytes")]
    TooLarge {
        /// Payload length.
        len: usize,
        /// Limit in force.
        max: usize,
    },
    /// bincode rejected the bytes (truncated, wrong type, invalid value).
    #[error("malformed message of {len} bytes: {source}")]
    Malformed {
        /// Payload length.
        len: usize,
        /// bincode's reason.
        #[source]
        source: bincode::error::DecodeError,
    },
    /// A value was decoded but bytes were left over (a different message type).
    #[error("message decoded from {used} of {len} bytes; trailing bytes are not allowed")]
    TrailingBytes {
        /// Bytes consumed.
        used: usize,
        /// Payload length.
        len: usize,
    },
    /// The value could not be encoded (serde error or over the limit).
    #[error("cannot encode message: {source}")]
    Encode {
        /// bincode's reason.
        #[source]
        source: bincode::error::EncodeError,
    },
}

/// Encodes `value` into `buf` (cleared first, capacity reused); returns the length.
///
/// # Errors
/// [`CodecError::Encode`] when serde fails, [`CodecError::TooLarge`] over
/// [`MAX_VARIABLE_MESSAGE_BYTES`].
pub fn encode_message<T: Serialize>(value: &T, buf: &mut Vec<u8>) -> Result<usize, CodecError> {
    buf.clear();
    bincode::serde::encode_into_std_write(value, buf, codec())
        .map_err(|source| CodecError::Encode { source })?;
    if buf.len() > MAX_VARIABLE_MESSAGE_BYTES {
        return Err(CodecError::TooLarge {
            len: buf.len(),
            max: MAX_VARIABLE_MESSAGE_BYTES,
        });
    }
    Ok(buf.len())
}

/// Decodes a `T` from exactly `bytes`, refusing payloads longer than `max_bytes`
/// (clamped to [`MAX_VARIABLE_MESSAGE_BYTES`]).
///
/// # Errors
/// [`CodecError::TooLarge`], [`CodecError::Malformed`] or [`CodecError::TrailingBytes`].
pub fn decode_message<T: DeserializeOwned>(
    bytes: &[u8],
    max_bytes: usize,
) -> Result<T, CodecError> {
    let max = max_bytes.min(MAX_VARIABLE_MESSAGE_BYTES);
    if bytes.len() > max {
        return Err(CodecError::TooLarge {
            len: bytes.len(),
            max,
        });
    }
    let (value, used) = bincode::serde::decode_from_slice(bytes, codec()).map_err(|source| {
        CodecError::Malformed {
            len: bytes.len(),
            source,
        }
    })?;
    if used != bytes.len() {
        return Err(CodecError::TrailingBytes {
            used,
            len: bytes.len(),
        });
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Snapshot {
        kf_ids: Vec<u64>,
        points: Vec<[f64; 3]>,
        note: String,
    }

    fn sample() -> Snapshot {
        Snapshot {
            kf_ids: vec![3, 5, 8],
            points: (0..100).map(|i| [i as f64, 0.5, -2.0]).collect(),
            note: "local map".to_string(),
        }
    }

    #[test]
    fn round_trip_reuses_the_buffer() {
        let mut buf = Vec::new();
        let n = encode_message(&sample(), &mut buf).unwrap();
        // Fixint: 8 (len) + 24 + 8 (len) + 2400 + 8 (len) + 9 bytes.
        assert_eq!(n, 8 + 24 + 8 + 2400 + 8 + 9);
        let back: Snapshot = decode_message(&buf, 1 << 20).unwrap();
        assert_eq!(back, sample());
        let cap = buf.capacity();
        encode_message(&sample(), &mut buf).unwrap();
        assert_eq!(buf.capacity(), cap);
    }

    #[test]
    fn every_truncation_is_an_error() {
        let mut buf = Vec::new();
        encode_message(&sample(), &mut buf).unwrap();
        for cut in 0..buf.len() {
            let r = decode_message::<Snapshot>(&buf[..cut], 1 << 20);
            assert!(matches!(r, Err(CodecError::Malformed { .. })), "cut {cut}");
        }
    }

    #[test]
    fn oversized_and_trailing_bytes_are_errors() {
        let mut buf = Vec::new();
        encode_message(&sample(), &mut buf).unwrap();
        let r = decode_message::<Snapshot>(&buf, 100);
        assert!(matches!(
            r,
            Err(CodecError::TooLarge {
                len: 2457,
                max: 100
            })
        ));
        buf.extend_from_slice(&[0, 0, 0]);
        let r = decode_message::<Snapshot>(&buf, 1 << 20);
        assert!(matches!(
            r,
            Err(CodecError::TrailingBytes {
                used: 2457,
                len: 2460
            })
        ));
    }

    #[test]
    fn garbage_and_huge_length_prefixes_are_errors() {
        // A length prefix claiming 2^62 elements must not allocate or loop forever.
        let mut huge = (1u64 << 62).to_le_bytes().to_vec();
        huge.extend_from_slice(&[0xAB; 64]);
        assert!(decode_message::<Snapshot>(&huge, 1 << 20).is_err());
        // A deterministic pseudo-random byte soup (splitmix64).
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for len in [1usize, 7, 64, 500, 4096] {
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                    let mut z = state;
                    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                    (z ^ (z >> 31)) as u8
                })
                .collect();
            assert!(
                decode_message::<Snapshot>(&bytes, 1 << 20).is_err(),
                "len {len}"
            );
        }
    }
}
