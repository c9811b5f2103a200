//! Data association between the map and the current frame: points by projection in the
//! keypoint grid, lines through the line grid (with the extension search), and the
//! exhaustive descriptor matching used when there is no pose to project with.

mod exhaustive;
mod lines;
mod points;

pub use exhaustive::match_descriptors;
pub use lines::{LineMatchConfig, LineProjectionMatcher, LineWindow};
pub use points::{
    PointMatchConfig, PointProjectionMatcher, PointWindow, ProjectionCandidate, ScalePyramid,
};
