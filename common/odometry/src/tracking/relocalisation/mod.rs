//! Relocalisation of a lost frame: first by the tracker, against the points around its
//! reference keyframe ([`around_reference`]); then by the mapping half, which owns the
//! whole map, against every keyframe found by place recognition ([`against_map`]).

pub(crate) mod against_map;
pub(crate) mod around_reference;
