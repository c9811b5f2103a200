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

use crate::depth::alignment::DepthAlignmentConfig;
use crate::depth::grid::{DepthGrid, IntensityLevel, PosedGrid};
use gfs_core::camera::PinholeCamera;
use gfs_optim::PhotometricObservation;
use nalgebra::Point3;

/// Pairs a reference's depth and intensities with a frame's intensity grid.
#[derive(Debug, Default)]
pub struct PhotometricAssociator {
    observations: Vec<PhotometricObservation>,
    /// Whether a pair of images without dithering was reported.
    reported_undithered: bool,
}

impl PhotometricAssociator {
    /// The reference nodes (`reference` at `reference_from_world`) that project into
    /// `current`'s intensities at `level` at `current_from_world` and are not hidden
    /// there by a nearer surface of its depth, as world points with their reference
    /// intensities at `level`; empty with `photometric_sigma` 0 or without intensities.
    pub fn associate(
        &mut self,
        config: &DepthAlignmentConfig,
        camera: &PinholeCamera,
        current: PosedGrid,
        reference: PosedGrid,
        level: IntensityLevel,
    ) -> &[PhotometricObservation] {
        let PosedGrid {
            grid: current,
            camera_from_world: current_from_world,
        } = current;
        let PosedGrid {
            grid: reference,
            camera_from_world: reference_from_world,
        } = reference;
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
        // The frame's gain over the reference where their samples meet.
        let (mut cross, mut square) = (0.0, 0.0);
        let occlusion_m = config.occlusion_m();
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
                let Some(value) = image.intensity(uv.x, uv.y) else {
                    continue;
                };
                if current
                    .at_pixel(uv.x, uv.y)
                    .is_some_and(|(q, _)| (q.z - in_current.z).abs() > occlusion_m)
                {
                    continue;
                }
                cross += value * intensity;
                square += intensity * intensity;
                self.observations.push(PhotometricObservation {
                    point_in_world: (world_from_reference * in_reference).coords,
                    intensity,
                    reference_gradient: gradient,
                    inv_sigma2: 1.0
                        / (intensity_sigma2 + position_sigma2 * gradient.norm_squared()),
                });
            }
        }
        if !(current.rounding_is_dithered() && reference.rounding_is_dithered()) && square > 0.0 {
            self.keep_where_rounding_holds(config, cross / square, current, reference);
        }
        &self.observations
    }

    /// Between images too clean for their 8-bit rounding to be dithered, a change of
    /// exposure by `gain` moves the rounding contours of a surface shaded `I` with a
    /// gradient `g` by `|gain - 1| I / |g|` pixels, which the term would fit as motion
    /// (the record's "Images without noise under a drifting exposure"): only the
    /// samples whose contours move by less than the position sigma stay.
    fn keep_where_rounding_holds(
        &mut self,
        config: &DepthAlignmentConfig,
        gain: f64,
        current: &DepthGrid,
        reference: &DepthGrid,
    ) {
        let change = (gain - 1.0).abs();
        let position_sigma = config.photometric_position_sigma_px;
        let before = self.observations.len();
        self.observations
            .retain(|o| change * o.intensity <= position_sigma * o.reference_gradient.norm());
        if !self.reported_undithered {
            self.reported_undithered = true;
            tracing::warn!(
                frame_noise = current.pixel_noise,
                reference_noise = reference.pixel_noise,
                gain,
                kept = self.observations.len(),
                of = before,
                "the images' noise (gray levels) is below what dithers their 8-bit \
                 rounding: the photometric term reads them only where a change of \
                 exposure moves their rounding contours by less than \
                 [tracking.depth] photometric_position_sigma_px (reported once)"
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{camera, textured_planes_depth};
    use nalgebra::Isometry3;

    /// A wall 2 m ahead painted with a faint shading (up to 0.02 gray levels a pixel).
    const WALL: [([f64; 3], f64); 1] = [([0.0, 0.0, 1.0], 2.0)];

    fn paint(p: &nalgebra::Vector3<f64>) -> f64 {
        150.0 + 2.0 * (3.0 * p.x).sin() + 1.5 * (2.0 * p.y).cos()
    }

    /// The samples of the wall seen twice from one pose, the frame's exposure `gain`
    /// times the reference's, both images measured at `pixel_noise` gray levels.
    fn samples(gain: f32, pixel_noise: f32) -> usize {
        let pose = Isometry3::identity();
        let reference = DepthGrid {
            pixel_noise: Some(pixel_noise),
            ..textured_planes_depth(&camera(), &pose, &WALL, paint, 1)
        };
        let mut frame = textured_planes_depth(&camera(), &pose, &WALL, paint, 2);
        frame.intensity.iter_mut().for_each(|v| *v *= gain);
        frame.pixel_noise = Some(pixel_noise);
        let config = DepthAlignmentConfig {
            photometric_sigma: 0.4,
            ..DepthAlignmentConfig::default()
        };
        PhotometricAssociator::default()
            .associate(
                &config,
                &camera(),
                PosedGrid {
                    grid: &frame,
                    camera_from_world: &pose,
                },
                PosedGrid {
                    grid: &reference,
                    camera_from_world: &pose,
                },
                IntensityLevel::Cells,
            )
            .len()
    }

    #[test]
    fn clean_images_under_a_changed_exposure_are_read_only_where_their_contours_hold() {
        let all = samples(1.0, 1.4);
        assert!(all > 1000, "{all}");
        // Dithered images: every sample, whatever the exposure.
        assert_eq!(samples(1.02, 1.4), all);
        // Too clean to be dithered, 2 % brighter: the rounding contours of 150 gray
        // levels would move 3 levels / 0.02 levels a pixel = 150 pixels; none stays.
        assert_eq!(samples(1.02, 0.03), 0);
        // At one exposure the contours stay where they are: most samples stay (those
        // whose gradient is below what the fitted gain's noise moves them by go).
        let same_exposure = samples(1.0, 0.03);
        assert!(same_exposure > all * 9 / 10, "{same_exposure} of {all}");
    }
}
