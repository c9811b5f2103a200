//! Line homogenisation (section III-B, "Line Homogenization Strategies"): thin dense
//! clusters of lines so that the kept lines spread over the image.
//!
//! Three schemes, chosen by [`HomogeniseScheme`]: the quadtree over grid records (lines
//! traversing a cell), the midpoint quadtree (midpoints per cell), and the paper's
//! score ranking (formulas (1)-(3)). How many lines to keep comes from
//! [`adaptive_target`] (or a fixed number), see [`HomogeniseConfig`].

mod adaptive;
mod config;
mod homogeniser;
mod quadtree;
mod score;

pub use adaptive::adaptive_target;
pub use config::{HomogeniseConfig, HomogeniseScheme, ScorePenalty};
pub use homogeniser::Homogeniser;
