//! How raw 16-bit depth values become metres.

use serde::{Deserialize, Serialize};

/// `[depth]` table of a config: scale and valid range of the depth sensor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DepthConfig {
    /// Raw units per metre (5000 for TUM and ICL-NUIM, 1000 for 7-Scenes). Default 5000.
    pub scale: f64,
    /// Closest valid depth in metres; closer values are missing. Default 0.1.
    pub min_m: f32,
    /// Farthest valid depth in metres; farther values are missing. Default 10.
    pub max_m: f32,
}

impl Default for DepthConfig {
    fn default() -> Self {
        Self {
            scale: 5000.0,
            min_m: 0.1,
            max_m: 10.0,
        }
    }
}
