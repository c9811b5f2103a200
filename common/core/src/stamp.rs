//! Capture stamps as integer nanoseconds since the epoch: what a camera driver stamps
//! (ROS 2 `builtin_interfaces/Time`, `sec` + `nanosec`) and a TUM list writes
//! (`1305031102.175304`), carried from the source to every output bit for bit. A stamp
//! through `f64` seconds comes back up to a few hundred nanoseconds off at today's
//! epoch, and a subscriber pairing odometry with its image by stamp then finds none.
//! The motion model computes in seconds ([`Stamp::secs`]); the stamp handed on is the
//! one received.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Nanoseconds in a second.
const NANOS_PER_SEC: i64 = 1_000_000_000;
/// Digits of the fraction a stamp is written with at least (TUM lists' microseconds);
/// more when the nanoseconds need them.
const MIN_FRACTION_DIGITS: usize = 6;

/// A capture stamp, integer nanoseconds since the epoch; ordered as time is.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Stamp {
    nanos: i64,
}

impl Stamp {
    /// The stamp `nanos` nanoseconds after the epoch.
    pub const fn from_nanos(nanos: i64) -> Self {
        Self { nanos }
    }

    /// Nanoseconds after the epoch.
    pub const fn nanos(self) -> i64 {
        self.nanos
    }

    /// The stamp of a ROS 2 `Time`; `None` when `nanosec` is not below 1e9.
    pub fn from_sec_nanosec(sec: i32, nanosec: u32) -> Option<Self> {
        (i64::from(nanosec) < NANOS_PER_SEC)
            .then(|| Self::from_nanos(i64::from(sec) * NANOS_PER_SEC + i64::from(nanosec)))
    }

    /// ROS 2 `Time` (`sec`, `nanosec`); `sec` saturates outside the `i32` range (years
    /// before 1902 or after 2037, which no capture stamp is).
    pub fn sec_nanosec(self) -> (i32, u32) {
        let sec = self.nanos.div_euclid(NANOS_PER_SEC);
        let nanosec = self.nanos.rem_euclid(NANOS_PER_SEC) as u32;
        (sec.clamp(i32::MIN.into(), i32::MAX.into()) as i32, nanosec)
    }

    /// The stamp `seconds` stands for: its shortest decimal form (the one that reads
    /// back as the same `f64`) to the nanosecond, so a stamp that went through
    /// [`Stamp::secs`] comes back exact when it had up to about 16 significant digits
    /// (a TUM list's microseconds do); `None` when not finite or out of range.
    pub fn from_secs(seconds: f64) -> Option<Self> {
        seconds.to_string().parse().ok()
    }

    /// The system clock now (the stamp of a report, not of a capture).
    pub fn now() -> Self {
        let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH);
        Self::from_nanos(since.map_or(0, |d| d.as_nanos().min(i64::MAX as u128) as i64))
    }

    /// Seconds after the epoch, for arithmetic only: the `f64` nearest to the stamp
    /// written in decimal, so a stamp from a TUM list and the same stamp from a message
    /// give the same number.
    pub fn secs(self) -> f64 {
        self.to_string().parse().unwrap_or(self.nanos as f64 * 1e-9)
    }

    /// Seconds from `earlier` to `self` (negative when `earlier` is later).
    pub fn secs_since(self, earlier: Stamp) -> f64 {
        (self.nanos - earlier.nanos) as f64 * 1e-9
    }
}

/// `sec.fraction` in decimal, with at least six digits of fraction and as many more as
/// the nanoseconds need: `1305031102.175304`, `1305031102.175304001`.
impl fmt::Display for Stamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sign = if self.nanos < 0 { "-" } else { "" };
        let abs = self.nanos.unsigned_abs();
        let (sec, frac) = (abs / NANOS_PER_SEC as u64, abs % NANOS_PER_SEC as u64);
        let digits = format!("{frac:09}");
        let keep = digits.trim_end_matches('0').len().max(MIN_FRACTION_DIGITS);
        write!(f, "{sign}{sec}.{}", &digits[..keep])
    }
}

/// A text that is not a stamp in decimal seconds.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{text:?} is not a stamp in decimal seconds ({reason})")]
pub struct StampParseError {
    /// The text (cut to 40 characters).
    pub text: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

/// Parses decimal seconds (`1305031102.175304`, `-0.5`, `12`) exactly, without floats;
/// digits past the ninth of the fraction round to the nearest nanosecond.
impl FromStr for Stamp {
    type Err = StampParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let error = |reason| StampParseError {
            text: text.chars().take(40).collect(),
            reason,
        };
        let (negative, unsigned) = match text.strip_prefix('-') {
            Some(rest) => (true, rest),
            None => (false, text.strip_prefix('+').unwrap_or(text)),
        };
        let (whole, fraction) = unsigned.split_once('.').unwrap_or((unsigned, ""));
        let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
        if whole.is_empty() && fraction.is_empty() || !digits(whole) || !digits(fraction) {
            return Err(error("digits with an optional '.' fraction expected"));
        }
        let sec: i64 = match whole {
            "" => 0,
            w => w.parse().map_err(|_| error("too many seconds"))?,
        };
        let mut nanos: i64 = 0;
        for (i, b) in fraction.bytes().enumerate().take(9) {
            nanos += i64::from(b - b'0') * 10i64.pow(8 - i as u32);
        }
        nanos += i64::from(fraction.as_bytes().get(9).is_some_and(|&b| b >= b'5'));
        let total = sec
            .checked_mul(NANOS_PER_SEC)
            .and_then(|s| s.checked_add(nanos))
            .ok_or_else(|| error("too many seconds"))?;
        Ok(Self::from_nanos(if negative { -total } else { total }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nine_digit_stamps_round_trip_exactly_through_text_and_ros_time() {
        for text in [
            "1305031102.175304",
            "1305031102.175304001",
            "1305031102.123456789",
            "1700000000.999999999",
            "0.000000",
            "0.000000001",
            "-0.500000",
            "1000.033333333",
        ] {
            let stamp: Stamp = text.parse().unwrap();
            assert_eq!(stamp.to_string(), text);
            let (sec, nanosec) = stamp.sec_nanosec();
            assert_eq!(Stamp::from_sec_nanosec(sec, nanosec), Some(stamp), "{text}");
        }
        let stamp: Stamp = "1305031102.175304".parse().unwrap();
        assert_eq!(stamp.sec_nanosec(), (1305031102, 175_304_000));
        assert_eq!(stamp.nanos(), 1_305_031_102_175_304_000);
    }

    #[test]
    fn parsing_needs_no_float_and_rounds_past_the_ninth_digit() {
        assert_eq!("12".parse::<Stamp>().unwrap().nanos(), 12 * NANOS_PER_SEC);
        assert_eq!(".5".parse::<Stamp>().unwrap().nanos(), NANOS_PER_SEC / 2);
        let long: Stamp = "1.1234567895".parse().unwrap();
        assert_eq!(long.nanos(), 1_123_456_790);
        for bad in [
            "",
            ".",
            "1.2.3",
            "1e9",
            "abc",
            "1 2",
            "--1",
            "99999999999999999999",
        ] {
            assert!(bad.parse::<Stamp>().is_err(), "{bad:?}");
        }
        let e = "x".repeat(1000).parse::<Stamp>().unwrap_err();
        assert_eq!(e.text.len(), 40);
    }

    #[test]
    fn seconds_are_the_decimal_value_and_differences_exact() {
        let a: Stamp = "1305031102.175304".parse().unwrap();
        assert_eq!(a.secs(), 1305031102.175304);
        let b: Stamp = "1305031102.208839".parse().unwrap();
        assert!((b.secs_since(a) - 0.033535).abs() < 1e-12);
        assert!(a < b);
        assert_eq!(
            Stamp::from_secs(1000.0 + 2.0 / 30.0).unwrap().to_string(),
            "1000.066666667"
        );
        assert_eq!(Stamp::from_secs(f64::NAN), None);
        // Through f64 seconds and back: exact for a TUM stamp (not `.175303936`).
        assert_eq!(Stamp::from_secs(a.secs()), Some(a));
    }
}
