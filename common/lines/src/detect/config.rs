//! The `[lines.detect]` table of the configuration file.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::join::JoinConfig;

/// Parameters of the EDLines detector and of the joining step.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct DetectConfig {
    /// Minimum Sobel gradient magnitude `|gx| + |gy|` (0..255 image units) of an edge pixel.
    /// Default 36: EDLines paper (Sobel operator on the 5x5 sigma-1 smoothed image).
    pub gradient_threshold: u16,
    /// An anchor must exceed both neighbours across the edge by this much.
    /// Default 8: EDLines paper.
    pub anchor_threshold: u16,
    /// Anchors are tested on every `scan_interval`-th pixel along the edge direction.
    /// Default 2: every other pixel; a chain started from one anchor covers the rest.
    pub scan_interval: usize,
    /// Maximum distance (px) of a chain pixel to the fitted line.
    /// Default 1.0: EDLines paper.
    pub max_fit_error: f32,
    /// Angle tolerance (degrees) between the gradient and the line normal for a pixel to
    /// count as aligned in the validation. Default 22.5 (pi/8): EDLines / LSD.
    pub aligned_angle_deg: f32,
    /// Accepted number of false alarms of a segment (NFA <= this).
    /// Default 1.0: EDLines / LSD ("epsilon = 1", one false detection per image on noise).
    pub max_nfa: f64,
    /// Joining and extension of the detected segments (ELSED-style).
    pub join: JoinConfig,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            gradient_threshold: 36,
            anchor_threshold: 8,
            scan_interval: 2,
            max_fit_error: 1.0,
            aligned_angle_deg: 22.5,
            max_nfa: 1.0,
            join: JoinConfig::default(),
        }
    }
}

/// A value of `[lines.detect]` outside its range.
#[derive(Debug, Error, PartialEq)]
pub enum DetectConfigError {
    /// `field` holds `value`, which is not in the expected range.
    #[error("lines.detect.{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// The field, relative to `[lines.detect]` (e.g. `join.merge_gap`).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The accepted range, in words.
        expected: &'static str,
    },
}

/// `value` clamped to `[lo, hi]`, NaN taken as `lo`: configs out of range never panic.
pub(crate) fn clamped(value: f32, lo: f32, hi: f32) -> f32 {
    if value.is_nan() {
        lo
    } else {
        value.clamp(lo, hi)
    }
}

/// `Ok` when `lo < value <= hi` (NaN fails).
pub(crate) fn check(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    expected: &'static str,
) -> Result<(), DetectConfigError> {
    if value > lo && value <= hi {
        Ok(())
    } else {
        Err(DetectConfigError::OutOfRange {
            field,
            value,
            expected,
        })
    }
}

impl DetectConfig {
    /// Checks every value (and the `join` table) against its range.
    ///
    /// # Errors
    /// [`DetectConfigError::OutOfRange`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), DetectConfigError> {
        let threshold = f64::from(self.gradient_threshold);
        check("gradient_threshold", threshold, 0.0, 2040.0, "in [1, 2040]")?;
        let anchor = f64::from(self.anchor_threshold) + 1.0;
        check("anchor_threshold", anchor, 0.0, 2041.0, "in [0, 2040]")?;
        let scan = self.scan_interval as f64;
        check("scan_interval", scan, 0.0, 16.0, "in [1, 16]")?;
        check(
            "max_fit_error",
            self.max_fit_error.into(),
            0.0,
            10.0,
            "in (0, 10] px",
        )?;
        check(
            "aligned_angle_deg",
            self.aligned_angle_deg.into(),
            0.0,
            90.0,
            "in (0, 90] degrees",
        )?;
        check(
            "max_nfa",
            self.max_nfa,
            0.0,
            f64::MAX,
            "positive and finite",
        )?;
        self.join.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_name_their_field() {
        assert_eq!(DetectConfig::default().validate(), Ok(()));
        let c = DetectConfig {
            scan_interval: 0,
            ..DetectConfig::default()
        };
        assert!(matches!(
            c.validate(),
            Err(DetectConfigError::OutOfRange {
                field: "scan_interval",
                ..
            })
        ));
        let mut c = DetectConfig::default();
        c.join.merge_gap = f32::NAN;
        let err = c.validate().unwrap_err();
        assert!(
            err.to_string().contains("lines.detect.join.merge_gap"),
            "{err}"
        );
    }
}
