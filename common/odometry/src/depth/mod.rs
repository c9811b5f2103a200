//! Depth and intensity as tracking measurements, for scenes where points vanish (bare
//! walls, a floor): beyond the paper, which tracks on features only. A frame's depth is
//! kept as a coarse [`grid`] of points, normals and mean gray levels, whose depth errs as
//! its sensor's [`noise`] says; the [`alignment`]
//! pairs its nodes with the reference's surfaces (point to plane); the [`photometric`]
//! term reads the reference's intensities in the frame, fixing what the geometry leaves
//! free; a keyframe reference's intensities are averaged over the frames tracked against
//! it ([`reference_intensity`]); the camera's [`vignetting`] is estimated online and
//! taken out of the intensities. The tracker (`crate::tracking::tracker`) decides when
//! these terms join its pose optimisation.

pub(crate) mod alignment;
pub(crate) mod grid;
pub(crate) mod noise;
pub(crate) mod photometric;
pub(crate) mod reference_intensity;
pub(crate) mod vignetting;
