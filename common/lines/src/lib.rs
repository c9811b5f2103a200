//! Line features of GFS-VO (paper sections III-A and III-B).
//!
//! **What.** From a gray frame and its depth: straight segments (EDLines: smoothing,
//! gradients, anchors, edge drawing, least-squares fitting, NFA validation), joined
//! ELSED-style across small gaps and extended along the gradient, indexed in a grid
//! (line <-> cells both ways), thinned by one of the paper's homogenisation schemes
//! (quadtree, midpoint quadtree, score with formulas 1-3; adaptive target), described
//! with binary LBD, and lifted to 3D lines from depth.
//!
//! **Why.** Lines give stable constraints where points are few, and the grid makes both
//! homogenisation and tracking (grid-based matching, extension search) cheap.
//!
//! **Model.** [`LineExtractor::extract`] runs detect -> join -> grid + homogenise -> LBD
//! -> 3D lines into a reused [`LineFeatures`] (struct of arrays: segments in undistorted
//! pixels, `[u64; 4]` descriptors, [`Line3`] in the camera frame), and records the time
//! of each step.
//!
//! ```
//! use gfs_core::{Image, camera::PinholeCamera};
//! use gfs_lines::{LineConfig, LineExtractor, LineFeatures};
//! let mut gray = Image::new(160, 120);
//! for v in 30..90 {
//!     for u in 40..120 {
//!         gray.set(u, v, 200u8);
//!     }
//! }
//! let mut depth = Image::new(160, 120);
//! depth.fill(2.0f32);
//! let camera = PinholeCamera::new(150.0, 150.0, 79.5, 59.5, 160, 120);
//! let mut extractor = LineExtractor::new(LineConfig::default());
//! let mut features = LineFeatures::default();
//! extractor.extract(&gray.view(), &depth.view(), &camera, &mut features);
//! assert_eq!(features.len(), 4); // the four sides of the bright rectangle
//! ```
#![warn(missing_docs)]

pub mod detect;
pub mod extractor;
pub mod grid;
pub mod homogenise;
pub mod join;
pub mod lbd;
pub mod lines3d;
mod segment;

pub use segment::{DetectedLine, Segment};

pub use extractor::{LineConfig, LineExtractor, LineFeatures};
pub use lbd::LbdDescriptor;
pub use lines3d::Line3;

#[cfg(test)]
mod fixtures;
pub use {
    detect::{DetectConfig, DetectConfigError, LineDetector},
    join::JoinConfig,
};
