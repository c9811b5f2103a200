//! Local mapping (paper section III-C, "Keyframe Select and Filter" and "Local
//! Optimization"): the [`keyframe_policy`] decides when a tracked frame becomes a
//! keyframe (points **or** lines falling off); the [`mapper`] inserts it, makes new map
//! points and lines from its depth, fuses duplicates, runs the local bundle adjustment
//! assembled by [`local_ba`] (reprojection, structural and Manhattan terms, eq. 10-14)
//! and culls redundant keyframes; [`plane_mapping`] keeps the map's planes.

pub(crate) mod keyframe_policy;
pub(crate) mod local_ba;
pub(crate) mod mapper;
pub(crate) mod plane_mapping;
