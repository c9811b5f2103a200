//! The `[lines.detect]` table of the configuration file.

use serde::{Deserialize, Serialize};

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
