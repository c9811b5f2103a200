//! ORB point features for GFS-VO: the point front end of the paper (Sec. III, ORB
//! features as in ORB-SLAM2), and the matching utilities the tracker builds on.
//!
//! Model, one frame:
//!
//! 1. **Pyramid** ([`OrbConfig::levels`] levels, factor [`OrbConfig::scale_factor`]):
//!    level 0 is the caller's image read in place, level k the bilinear resize of level
//!    k - 1. Keypoints keep [`EDGE`] pixels from their level's border, so every patch
//!    read fits inside the level and no padded copy is needed.
//! 2. **FAST-9 with score** on cells of about [`OrbConfig::cell_size`] pixels: threshold
//!    [`OrbConfig::fast_threshold`], retried at [`OrbConfig::fast_min_threshold`] in a cell
//!    that found nothing, then 3x3 non-maximum suppression.
//! 3. **Quadtree distribution** under a per-level budget (geometric series summing to
//!    [`OrbConfig::features`]): the strongest corner of each node is kept.
//! 4. **Orientation** by intensity centroid on a radius-15 disc, and a 256-bit
//!    **steered BRIEF** on the level smoothed by a 7x7, sigma-2 Gaussian.
//! 5. **Output** in level-0 undistorted pixels ([`KeyPoint`], `#[repr(C)]`, with the
//!    depth at the keypoint, [`keypoint_depth`]: at an occlusion edge the nearer
//!    surface's, or none at a T-junction) plus [`Descriptor`]s, index-aligned in
//!    [`OrbFeatures`].
//!
//! [`OrbExtractor`] owns every buffer and reuses it frame to frame; it records the time
//! of each step of its last call ([`OrbTimings`]).
//!
//! Speed (`gfsvo bench points`, the 300 frames of `tum_fr1_rpy_head300`, one thread,
//! AVX2 chosen at run time, fastest of 3 runs per frame, median): 4.3-4.4 ms per
//! 640x480 frame for 1000 features (pyramid 0.67, FAST + distribution 2.4-2.5,
//! orientation + descriptors 1.2), the same as OpenCV 5.0's `ORB` (4.3 ms, same
//! parameters, measured the same way), which does less: on these blurry frames about
//! three cells in four find no corner at threshold 20 and are searched again at 7.
//! Without that retry (`fast_min_threshold = 20`) the extractor takes 3.4 ms.
//!
//! Matching: [`hamming`], [`best_two`] with [`BestMatch::passes_ratio`],
//! [`RotationHistogram`] (rotation consistency), [`KeyPointGrid`] (search by
//! projection in a window).
//!
//! ```
//! use gfs_core::GrayImage;
//! use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures, KeyPointGrid, best_two};
//!
//! // A checkerboard of 16-pixel squares, slightly irregular so corners differ.
//! let (w, h): (usize, usize) = (160, 120);
//! let data = (0..w * h)
//!     .map(|i| {
//!         let (x, y) = (i % w, i / w);
//!         if ((x / 16) + (y / 16)).is_multiple_of(2) { 40 + (x % 7) as u8 } else { 210 - (y % 5) as u8 }
//!     })
//!     .collect();
//! let image = GrayImage::from_vec(w, h, data)?;
//!
//! let mut orb = OrbExtractor::new(OrbConfig { features: 100, ..OrbConfig::default() })?;
//! let mut features = OrbFeatures::default();
//! orb.extract(image.view(), None, &mut features)?;
//! assert!(!features.is_empty() && features.len() <= 100);
//!
//! // Every descriptor is its own best match; the grid finds keypoints near a position.
//! let first = &features.descriptors[0];
//! let m = best_two(first, features.descriptors.iter().enumerate()).unwrap();
//! assert_eq!(m.distance, 0);
//! let mut grid = KeyPointGrid::new(w, h, 16.0);
//! grid.build(&features.keypoints);
//! let mut near = Vec::new();
//! let kp = features.keypoints[0];
//! grid.features_in_area(kp.u, kp.v, 3.0, 0, u32::MAX, &mut near);
//! assert!(near.contains(&0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

mod blur;
mod brief;
mod config;
mod distribute;
mod extractor;
mod fast;
mod grid;
mod keypoint;
mod keypoint_depth;
mod matching;
mod orientation;
mod pattern;
mod pyramid;
mod rotation;
mod simd;

pub use config::{MAX_LEVELS, OrbConfig, OrbConfigError};
pub use extractor::{EDGE, OrbError, OrbExtractor, OrbTimings};
pub use fast::{Corner, RING_RADIUS, detect_fast};
pub use grid::{DEFAULT_CELL_PX, KeyPointGrid};
pub use keypoint::{Descriptor, KeyPoint, OrbFeatures};
pub use keypoint_depth::{depth_at, keypoint_depth};
pub use matching::{BestMatch, best_two, hamming};
pub use orientation::HALF_PATCH;
pub use rotation::{ROTATION_BINS, RotationHistogram};
