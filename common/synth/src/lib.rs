//! Synthetic RGB-D sequences with exact ground truth: the test data of every GFS-VO
//! crate and the built-in default sequence of `gfsvo run`.
//!
//! **What.** A procedural indoor Manhattan scene ([`Scene`]: walls, floor, ceiling,
//! furniture boxes, door / window / picture frames, objects rotated about the vertical,
//! each surface with its own procedural texture: bricks, tiles, wood, posters with
//! glyph text, book spines...) is ray cast ([`render_view`]) along a smooth hand-held-like
//! trajectory ([`TrajectoryKind`]) with the effects of a depth camera
//! ([`NoiseConfig`], [`Sensor`]: ideal, Kinect v1, RealSense, time of flight), and written in TUM RGB-D layout ([`SynthSequence::write_tum`]).
//!
//! **Why.** Tests need data with known answers and no download: poses, depth, planes
//! ([`Scene::planes`]), straight 3D edges ([`Scene::edges`]) and the Manhattan frame
//! ([`Scene::manhattan_axes`], the world axes) are all exact.
//!
//! **Model.** World frame z up, floor at z = 0, walls along x and y. Poses are `T_wc`
//! (`world_from_camera`), camera x right, y down, z forward. Depth is `z` along the
//! optical axis (not the ray length), exact at the pixel centre (f32 of the nearest hit)
//! when noise is off; colour is antialiased at edges. Everything is a pure function of
//! [`SynthConfig`]: same config, same bits, whatever the thread count.
//!
//! ```
//! use gfs_synth::{NoiseConfig, SceneKind, SynthConfig, SynthSequence, TrajectoryKind};
//! let seq = SynthSequence::new(SynthConfig {
//!     scene: SceneKind::Corridor,
//!     trajectory: TrajectoryKind::Fast,
//!     frames: 2,
//!     camera: SynthConfig::scaled_camera(160),
//!     noise: NoiseConfig::none(),
//!     ..SynthConfig::default()
//! });
//! let frame = seq.render(1);
//! // Back-project a pixel with the ground-truth pose: it lies on a scene surface.
//! let cam = seq.config().camera;
//! let z = f64::from(frame.depth.get(80, 60).unwrap());
//! let p_in_world = frame.pose * cam.back_project(80.0, 60.0, z);
//! assert!(seq.scene().distance_to_surfaces(&p_in_world) < 1e-5);
//! ```
#![warn(missing_docs)]

mod circuit;
mod error;
mod imu;
mod lens;
mod noise;
mod render;
mod rng;
mod scene;
mod scenes;
mod sensor;
#[cfg(test)]
mod sensor_tests;
mod sequence;
mod texture;
mod trajectory;
mod tum;

pub use error::SynthError;
pub use imu::SynthImu;
pub use lens::typical_lens;
pub use noise::{AUTO_EXPOSURE_TARGET, DEPTH_SCALE, DEPTH_SIGMA_PER_Z2, NoiseConfig};
pub use render::{render_luma_view, render_view};
pub use rng::SplitMix64;
pub use scene::{Aabb, EdgeKind, MIN_CLEARANCE, Quad, Scene, SceneEdge, SceneKind, ScenePlane};
pub use sensor::{CorrelatedField, DepthModel, Sensor, TimeOfFlight, Triangulation, WAVES};
pub use sequence::{LUMA_WEIGHTS, SynthConfig, SynthFrame, SynthSequence, luma};
pub use texture::{Poster, PosterItem, Rgb, Texture};
pub use trajectory::TrajectoryKind;
pub use tum::cached_sequence;
