//! Planes and Manhattan axes of GFS-VO (paper Sec. III-A, Algorithm 1).
//!
//! What: from a depth frame, the planes it shows (normal, offset, size) and the scene's
//! Manhattan axes (MA), the three orthogonal directions that the tracker and the local
//! bundle adjustment tie map lines to; and for each 3D line, the axis it is parallel to.
//!
//! Why: the MA is the paper's "spatial feature". Its line <-> axis constraints (E_M of
//! the local BA) need axes that keep their identity and sign across frames, and the
//! paper spends 20-170 ms per frame on them; a strided normal grid and one BFS make
//! normals + planes + MA about 1 ms per VGA frame on one core (`gfsvo bench planes`).
//!
//! Model, per frame:
//! 1. [`NormalEstimator`]: the depth image is cut into `stride x stride` blocks, each
//!    back-projected to one 3D point; a node's normal is `(right - left) x (up - down)`
//!    over its grid neighbours (Algorithm 1), where no depth discontinuity intervenes.
//! 2. [`PlaneExtractor`]: breadth-first region growing over the grid (a node joins when
//!    its normal agrees with its neighbour's and with the region's mean); large regions
//!    are [`Plane`]s with the normalised mean normal, `n . p + d = 0` through the mean
//!    point; regions with the same normal and offset merge.
//! 3. [`ManhattanEstimator`]: the dominant orthogonal triplet of the plane normals and
//!    3D line directions, refined on SO(3), labelled consistently with the previous
//!    frame's axes moved by the predicted rotation; `None` when there is no structure.
//! 4. [`associate_lines`]: each line direction's axis within `line_axis_angle_deg`.
//!
//! ```
//! use gfs_core::{camera::PinholeCamera, Image};
//! use gfs_planes::{associate_lines, ManhattanEstimator, PlaneConfig, PlaneExtractor};
//! use nalgebra::Vector3;
//! # fn main() -> Result<(), gfs_planes::PlaneError> {
//! // A camera 1.5 m above a floor, looking straight ahead: the lower half sees the floor
//! // (y down, so the floor is y = 1.5 and its normal towards the camera is -y).
//! let cam = PinholeCamera::new(300.0, 300.0, 159.5, 119.5, 320, 240);
//! let mut depth = Image::<f32>::new(320, 240);
//! for v in 130..240 {
//!     let z = 1.5 * cam.fy / (v as f64 - cam.cy);
//!     for u in 0..320 {
//!         depth.set(u, v, z as f32);
//!     }
//! }
//! let config = PlaneConfig::default();
//! let mut extractor = PlaneExtractor::new(&config)?;
//! let mut planes = Vec::new();
//! extractor.extract(&depth.view(), &cam, &mut planes)?;
//! assert_eq!(planes.len(), 1);
//! assert!((planes[0].normal[1] + 1.0).abs() < 1e-4 && (planes[0].offset - 1.5).abs() < 1e-3);
//!
//! // The floor and two lines along the room's x and z axes give a full MA.
//! let lines = [Vector3::new(1.0f32, 0.0, 0.0), Vector3::new(0.0, 0.0, 1.0)];
//! let mut ma = ManhattanEstimator::new(&config)?;
//! let axes = ma.estimate(&planes, &lines, &[1.0, 1.0], None).expect("structure");
//! assert_eq!(axes.observed_count(), 3);
//! let mut labels = Vec::new();
//! associate_lines(&axes, &lines, config.line_axis_angle_deg.to_radians(), &mut labels);
//! assert!(labels.iter().all(Option::is_some) && labels[0] != labels[1]);
//! # Ok(())
//! # }
//! ```
#![warn(missing_docs)]

mod axes;
mod config;
mod error;
mod extractor;
mod manhattan;
mod normals;

pub use axes::{ManhattanAxes, associate_lines};
pub use config::PlaneConfig;
pub use error::PlaneError;
pub use extractor::{ExtractTimings, NO_PLANE, Plane, PlaneExtractor};
pub use manhattan::ManhattanEstimator;
pub use normals::NormalEstimator;
