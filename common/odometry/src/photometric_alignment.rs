//! The photometric term of the depth alignment (`[tracking.depth] photometric_sigma`):
//! each sampled node of the reference's depth grid, with the reference's intensity where
//! it projects there, becomes a world point whose intensity the frame's intensity grid
//! must show where it projects ([`gfs_optim::residuals::Photometric`]).
//! Where the geometry leaves a direction free (a wall and the floor, along their edge),
//! the shading and the faint texture of the surfaces still fix it, as in RGB-D
//! odometry with photometric and depth terms (Steinbruecker et al. 2011, Kerl et al.
//! 2013).
//!
//! The exposure may drift between the two frames: the pose optimisation fits the gain
//! with the pose ([`gfs_optim::PhotometricTerm`]). A node's point is uncertain by a pixel or two across the image (the mean of a block of
//! depth pixels, a block across an edge mixes two surfaces): its intensity difference
//! is uncertain by that times the gradient, `sigma^2 = sigma_i^2 + (sigma_px |grad
//! I|)^2`, so that the creases' shading steps do not outweigh the smooth shading.

use crate::depth_alignment::DepthAlignmentConfig;
use crate::depth_grid::{DepthGrid, IntensityLevel};
use gfs_core::camera::PinholeCamera;
use gfs_optim::PhotometricObservation;
use nalgebra::{Isometry3, Point3};

/// Pairs a reference's depth and intensities with a frame's intensity grid.
#[derive(Debug, Default)]
pub struct PhotometricAssociator {
    observations: Vec<PhotometricObservation>,
}

impl PhotometricAssociator {
    /// The reference nodes (`reference` at `reference_from_world`) that project into
    /// `current`'s intensities at `level` at `current_from_world` and are not hidden
    /// there by a nearer surface of its depth, as world points with their reference
    /// intensities at `level`; empty with `photometric_sigma` 0 or without intensities.
    #[allow(clippy::too_many_arguments)]
    pub fn associate(
        &mut self,
        config: &DepthAlignmentConfig,
        camera: &PinholeCamera,
        current: &DepthGrid,
        current_from_world: &Isometry3<f64>,
        reference: &DepthGrid,
        reference_from_world: &Isometry3<f64>,
        level: IntensityLevel,
    ) -> &[PhotometricObservation] {
        self.observations.clear();
        let (Some(image), Some(reference_image)) = (
            current.intensity_grid(level),
            reference.intensity_grid(level),
        ) else {
            return &self.observations;
        };
        if config.photometric_sigma <= 0.0 {
            return &self.observations;
        }
        let intensity_sigma2 = config.photometric_sigma.powi(2);
        // A reference point whose depth differs from the frame's there by more than the
        // coarsest association gate is on another surface (occluded or disoccluded).
        let occlusion_m = config.max_distance_m.first().copied().unwrap_or(0.08);
        let world_from_reference = reference_from_world.inverse();
        let current_from_reference = current_from_world * world_from_reference;
        let position_sigma2 = config.photometric_position_sigma_px.powi(2);
        let step = config.source_step.max(1);
        let width = reference.width as usize;
        for j in (step / 2..reference.height as usize).step_by(step) {
            for i in (step / 2..width).step_by(step) {
                let k = j * width + i;
                let Some((node, _)) = reference.node(k) else {
                    continue;
                };
                let in_reference = Point3::from(node);
                let Some((intensity, gradient)) = camera
                    .project(&in_reference)
                    .and_then(|uv| reference_image.intensity_and_gradient(uv.x, uv.y))
                else {
                    continue;
                };
                let in_current = current_from_reference * in_reference;
                let Some(uv) = camera.project(&in_current) else {
                    continue;
                };
                if image.intensity(uv.x, uv.y).is_none() {
                    continue;
                }
                if current
                    .at_pixel(uv.x, uv.y)
                    .is_some_and(|(q, _)| (q.z - in_current.z).abs() > occlusion_m)
                {
                    continue;
                }
                self.observations.push(PhotometricObservation {
                    point_in_world: (world_from_reference * in_reference).coords,
                    intensity,
                    reference_gradient: gradient,
                    inv_sigma2: 1.0
                        / (intensity_sigma2 + position_sigma2 * gradient.norm_squared()),
                });
            }
        }
        &self.observations
    }
}
