//! Parameters of the ORB extractor (`[points]` table of the config file).

use serde::Deserialize;
use thiserror::Error;

/// Parameters of [`crate::OrbExtractor`]. Defaults are ORB-SLAM2's settings for the
/// 640x480 TUM RGB-D / ICL-NUIM cameras (`ORBextractor.*` in its `TUM1.yaml`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OrbConfig {
    /// Features kept per frame over all levels. Default 1000 (ORB-SLAM2 `nFeatures`).
    pub features: usize,
    /// Scale between two pyramid levels. Default 1.2 (ORB-SLAM2 `scaleFactor`).
    pub scale_factor: f32,
    /// Number of pyramid levels. Default 8 (ORB-SLAM2 `nLevels`).
    pub levels: usize,
    /// FAST threshold tried first in every cell. Default 20 (ORB-SLAM2 `iniThFAST`).
    pub fast_threshold: u8,
    /// FAST threshold retried in a cell that found no corner. Default 7 (ORB-SLAM2 `minThFAST`).
    pub fast_min_threshold: u8,
    /// Side of the detection cells in pixels of each level. Default 30 (ORB-SLAM2 `W`).
    pub cell_size: usize,
    /// Closest valid keypoint depth in metres; closer is missing (0). Default 0.1, as the
    /// dataset `[depth]` default.
    pub depth_min_m: f32,
    /// Farthest valid keypoint depth in metres; farther is missing (0). Default 10, as the
    /// dataset `[depth]` default.
    pub depth_max_m: f32,
}

impl Default for OrbConfig {
    fn default() -> Self {
        Self {
            features: 1000,
            scale_factor: 1.2,
            levels: 8,
            fast_threshold: 20,
            fast_min_threshold: 7,
            cell_size: 30,
            depth_min_m: 0.1,
            depth_max_m: 10.0,
        }
    }
}

/// A field of [`OrbConfig`] is out of its valid range.
#[derive(Debug, Error, PartialEq)]
#[error("points.{field} = {value}: {reason}")]
pub struct OrbConfigError {
    /// The offending field, as named in the `[points]` table.
    pub field: &'static str,
    /// Its value, printed.
    pub value: String,
    /// The valid range.
    pub reason: &'static str,
}

/// Most pyramid levels accepted (1.2^15 = 15: a 640-pixel image is then 41 pixels wide).
pub const MAX_LEVELS: usize = 16;

impl OrbConfig {
    /// Checks every field.
    ///
    /// # Errors
    /// [`OrbConfigError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), OrbConfigError> {
        let fail = |field, value: String, reason| {
            Err(OrbConfigError {
                field,
                value,
                reason,
            })
        };
        if self.features == 0 || self.features > 100_000 {
            return fail(
                "features",
                self.features.to_string(),
                "must be in 1..=100000",
            );
        }
        if !(self.scale_factor > 1.0 && self.scale_factor <= 4.0) {
            return fail(
                "scale_factor",
                self.scale_factor.to_string(),
                "must be in (1, 4]",
            );
        }
        if self.levels == 0 || self.levels > MAX_LEVELS {
            return fail("levels", self.levels.to_string(), "must be in 1..=16");
        }
        if self.fast_min_threshold == 0 {
            return fail(
                "fast_min_threshold",
                self.fast_min_threshold.to_string(),
                "must be at least 1",
            );
        }
        if self.fast_threshold < self.fast_min_threshold {
            return fail(
                "fast_threshold",
                self.fast_threshold.to_string(),
                "must be at least fast_min_threshold",
            );
        }
        if !(8..=1000).contains(&self.cell_size) {
            return fail(
                "cell_size",
                self.cell_size.to_string(),
                "must be in 8..=1000",
            );
        }
        if !(self.depth_min_m >= 0.0 && self.depth_min_m.is_finite()) {
            return fail(
                "depth_min_m",
                self.depth_min_m.to_string(),
                "must be finite and >= 0",
            );
        }
        if !(self.depth_max_m > self.depth_min_m && self.depth_max_m.is_finite()) {
            return fail(
                "depth_max_m",
                self.depth_max_m.to_string(),
                "must be finite and > depth_min_m",
            );
        }
        Ok(())
    }

    /// Scale of `level` relative to level 0 (`scale_factor^level`), ORB-SLAM2's
    /// `mvScaleFactor`; the tracker weights a level-`l` observation by `1 / scale(l)^2`.
    pub fn scale(&self, level: usize) -> f32 {
        self.scale_factor.powi(level as i32)
    }

    /// Features wanted on each level: a geometric series of ratio `1 / scale_factor`
    /// summing to `features`, the remainder on the last level (ORB-SLAM2 `mnFeaturesPerLevel`).
    pub fn features_per_level(&self) -> Vec<usize> {
        let levels = self.levels.max(1);
        let factor = 1.0 / f64::from(self.scale_factor);
        let mut per_scale =
            self.features as f64 * (1.0 - factor) / (1.0 - factor.powi(levels as i32));
        let mut out = Vec::with_capacity(levels);
        let mut sum = 0usize;
        for _ in 0..levels - 1 {
            let n = per_scale.round() as usize;
            out.push(n);
            sum += n;
            per_scale *= factor;
        }
        out.push(self.features.saturating_sub(sum));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_budget_is_orb_slam2_series() {
        let c = OrbConfig::default();
        let per = c.features_per_level();
        assert_eq!(per, vec![217, 181, 151, 126, 105, 87, 73, 60]);
        assert_eq!(per.iter().sum::<usize>(), 1000);
        assert!(c.validate().is_ok());
        assert!((c.scale(7) - 3.583_18).abs() < 1e-4);
    }

    #[test]
    fn invalid_fields_are_named() {
        let c = OrbConfig {
            scale_factor: 1.0,
            ..OrbConfig::default()
        };
        assert_eq!(c.validate().unwrap_err().field, "scale_factor");
        let c = OrbConfig {
            fast_threshold: 5,
            ..OrbConfig::default()
        };
        let e = c.validate().unwrap_err();
        assert_eq!(e.field, "fast_threshold");
        assert!(e.to_string().contains("points.fast_threshold = 5"), "{e}");
        let c = OrbConfig {
            depth_max_m: f32::NAN,
            ..OrbConfig::default()
        };
        assert_eq!(c.validate().unwrap_err().field, "depth_max_m");
    }
}
