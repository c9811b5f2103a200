//! The reference keyframe's intensities averaged with the frames tracked against it.
//!
//! Two frames' images bound a pose on a bare wall to a few millimetres (the record's
//! "What the failing walls are made of"), and half of that noise is the reference's:
//! every frame tracked against a keyframe reads the same noisy cells, so their errors
//! move together, and the next keyframe inherits its frame's. Each frame tracked
//! against the keyframe sees its surfaces again with independent noise: brought back
//! onto the keyframe's cells through its depth and the frame's pose, at the keyframe's
//! exposure, the running mean of those views is a reference whose noise falls with the
//! frames it has seen.

use crate::depth::grid::{DepthGrid, IntensityLevel, PosedGrid};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::KeyFrameId;
use nalgebra::{Isometry3, Point3};

/// Views of a cell, the keyframe's own included, past which a frame's view no longer
/// moves the mean: the frames far along have drifted most, and a mean over a bounded
/// count keeps the newest frames' share.
const MAX_VIEWS: u16 = 8;

/// Running means of a reference keyframe's intensity cells over the frames tracked
/// against it.
#[derive(Debug, Default)]
pub struct ReferenceIntensity {
    /// The keyframe the sums belong to.
    keyframe: Option<KeyFrameId>,
    /// The keyframe's own cells, as its image gave them.
    own: Vec<f32>,
    /// Sums of the frames' views of each cell, at the keyframe's exposure.
    sums: Vec<f32>,
    /// Views of each cell, the keyframe's own included.
    views: Vec<u16>,
    /// `(cell, where its pixel's ray meets the keyframe's surface)` of each cell that
    /// has one, in the keyframe's camera frame: fixed by the keyframe's depth, so found
    /// once per keyframe rather than for every frame added.
    surfaces: Vec<(usize, Point3<f64>)>,
    /// `(cell, the frame's intensity there)` of the frame being added (reused).
    seen: Vec<(usize, f32)>,
}

impl ReferenceIntensity {
    /// Adds the view of `frame` (at `frame_from_world`) to the intensity cells of
    /// `reference` (keyframe `keyframe` at `reference_from_world`), in place: each cell
    /// whose surface the frame sees, not hidden by a nearer surface of its depth
    /// (`occlusion_m`), becomes the mean of the views so far, the frame's at the
    /// keyframe's exposure (a gain fitted over the cells both see). The coarse level is
    /// made again from the cells. Nothing without intensities in either.
    pub fn add_view(
        &mut self,
        camera: &PinholeCamera,
        keyframe: KeyFrameId,
        reference: &mut DepthGrid,
        reference_from_world: &Isometry3<f64>,
        frame: PosedGrid,
        occlusion_m: f64,
    ) {
        let PosedGrid {
            grid: frame,
            camera_from_world: frame_from_world,
        } = frame;
        let (Some(image), Some((s, width, height))) = (
            frame.intensity_grid(IntensityLevel::Cells),
            (reference.intensity_grid(IntensityLevel::Cells))
                .map(|cells| (cells.stride_px as usize, cells.width, cells.height)),
        ) else {
            return;
        };
        if self.keyframe != Some(keyframe) || self.own.len() != width * height {
            self.keyframe = Some(keyframe);
            self.own.clone_from(&reference.intensity);
            self.sums.clear();
            self.sums.resize(width * height, 0.0);
            self.views.clear();
            self.views.resize(width * height, 1);
            self.find_surfaces(camera, reference, s, width, height);
        }
        let frame_from_reference = frame_from_world * reference_from_world.inverse();
        let (mut cross, mut square) = (0.0f64, 0.0f64);
        self.seen.clear();
        for &(k, in_reference) in &self.surfaces {
            let in_frame = frame_from_reference * in_reference;
            let Some(uv) = camera.project(&in_frame) else {
                continue;
            };
            let Some(value) = image.intensity(uv.x, uv.y) else {
                continue;
            };
            if frame
                .at_pixel(uv.x, uv.y)
                .is_none_or(|(q, _)| (q.z - in_frame.z).abs() > occlusion_m)
            {
                continue;
            }
            let own = f64::from(self.own[k]);
            cross += value * own;
            square += value * value;
            self.seen.push((k, value as f32));
        }
        if square <= 0.0 || cross <= 0.0 {
            return;
        }
        // The keyframe's exposure over the frame's.
        let gain = (cross / square) as f32;
        for &(k, value) in &self.seen {
            if self.views[k] >= MAX_VIEWS {
                continue;
            }
            self.sums[k] += gain * value;
            self.views[k] += 1;
            reference.intensity[k] = (self.own[k] + self.sums[k]) / f32::from(self.views[k]);
        }
        reference.coarsen_intensity();
    }

    /// Fills `surfaces` with the cells of `reference` (`width x height` cells of
    /// `stride` pixels) whose centre's ray meets its surface, row by row.
    fn find_surfaces(
        &mut self,
        camera: &PinholeCamera,
        reference: &DepthGrid,
        stride: usize,
        width: usize,
        height: usize,
    ) {
        let centre = (stride as f64 - 1.0) / 2.0;
        self.surfaces.clear();
        for j in 0..height {
            for i in 0..width {
                let (u, v) = ((i * stride) as f64 + centre, (j * stride) as f64 + centre);
                if let Some(in_reference) = surface_point(reference, camera, u, v) {
                    self.surfaces.push((j * width + i, in_reference));
                }
            }
        }
    }
}

/// Where the ray of pixel `(u, v)` meets the surface of `grid`'s node there, in its
/// camera frame; `None` without a node or at a grazing angle.
fn surface_point(grid: &DepthGrid, camera: &PinholeCamera, u: f64, v: f64) -> Option<Point3<f64>> {
    let (point, normal) = grid.at_pixel(u, v)?;
    let ray = camera.back_project(u, v, 1.0).coords;
    let along = normal.dot(&ray);
    if along.abs() < 0.2 * ray.norm() {
        return None;
    }
    let depth = normal.dot(&point) / along;
    (depth > 0.0).then(|| Point3::from(ray * depth))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{camera, textured_planes_depth};
    use gfs_core::ids::KeyFrameId;
    use nalgebra::{Translation3, Vector3};

    /// A wall 2 m ahead, painted with a shading of a few gray levels.
    const WALL: [([f64; 3], f64); 1] = [([0.0, 0.0, 1.0], 2.0)];

    fn paint(p: &Vector3<f64>) -> f64 {
        150.0 + 4.0 * (3.0 * p.x).sin() + 3.0 * (2.0 * p.y).cos()
    }

    fn rms(a: &[f32], b: &[f32]) -> f64 {
        let sum: f64 = a.iter().zip(b).map(|(x, y)| f64::from(x - y).powi(2)).sum();
        (sum / a.len() as f64).sqrt()
    }

    #[test]
    fn seven_views_at_other_exposures_take_more_than_half_of_a_references_noise_away() {
        let camera = camera();
        let origin = Isometry3::identity();
        // The keyframe's cells without their noise: the mean of 64 renders.
        let renders = 64;
        let mut truth = vec![
            0.0f32;
            textured_planes_depth(&camera, &origin, &WALL, paint, 0)
                .intensity
                .len()
        ];
        for seed in 1000..1000 + renders {
            let render = textured_planes_depth(&camera, &origin, &WALL, paint, seed);
            truth
                .iter_mut()
                .zip(&render.intensity)
                .for_each(|(t, v)| *t += v / renders as f32);
        }
        let mut reference = textured_planes_depth(&camera, &origin, &WALL, paint, 1);
        let own = reference.intensity.clone();
        let mut views = ReferenceIntensity::default();
        for k in 0..7u64 {
            // Frames up to 6 cm aside (whole cells and fractions of them), their
            // exposure 4 % over or under the keyframe's.
            let frame_from_world =
                Isometry3::from(Translation3::new(-0.009 * k as f64, 0.004 * k as f64, 0.0));
            let mut frame = textured_planes_depth(&camera, &frame_from_world, &WALL, paint, 2 + k);
            let gain = if k % 2 == 0 { 1.04 } else { 0.96 };
            frame.intensity.iter_mut().for_each(|v| *v *= gain);
            views.add_view(
                &camera,
                KeyFrameId(1),
                &mut reference,
                &origin,
                PosedGrid {
                    grid: &frame,
                    camera_from_world: &frame_from_world,
                },
                0.08,
            );
        }
        // Columns 2 to the middle: inside every frame's view (the frames moved up to 17
        // px across them), each cell the mean of 8 views; 1 / sqrt(8) = 0.35.
        let width = reference.width as usize;
        let seen = |values: &[f32]| -> Vec<f32> {
            values
                .chunks(width)
                .flat_map(|row| row[2..width / 2].to_vec())
                .collect()
        };
        let before = rms(&seen(&own), &seen(&truth));
        let after = rms(&seen(&reference.intensity), &seen(&truth));
        assert!(before > 0.05, "{before}");
        assert!(
            after < 0.45 * before,
            "{after} against {before} gray levels"
        );
        // The coarse level follows the cells.
        let first = 0.25
            * (reference.intensity[0]
                + reference.intensity[1]
                + reference.intensity[width]
                + reference.intensity[width + 1]);
        assert!((reference.coarse_intensity[0] - first).abs() < 1e-4);
    }

    #[test]
    fn a_surface_in_front_of_the_reference_leaves_its_cells_alone() {
        let camera = camera();
        let origin = Isometry3::identity();
        let mut reference = textured_planes_depth(&camera, &origin, &WALL, paint, 1);
        let own = reference.intensity.clone();
        // The frame sees a board 1 m ahead where the keyframe saw the wall.
        let board = [([0.0, 0.0, 1.0], 1.0)];
        let frame = textured_planes_depth(&camera, &origin, &board, |_| 150.0, 2);
        let mut views = ReferenceIntensity::default();
        views.add_view(
            &camera,
            KeyFrameId(1),
            &mut reference,
            &origin,
            PosedGrid {
                grid: &frame,
                camera_from_world: &origin,
            },
            0.08,
        );
        assert_eq!(reference.intensity, own);
        // A new keyframe starts its means afresh.
        let frame = textured_planes_depth(&camera, &origin, &WALL, paint, 2);
        views.add_view(
            &camera,
            KeyFrameId(2),
            &mut reference,
            &origin,
            PosedGrid {
                grid: &frame,
                camera_from_world: &origin,
            },
            0.08,
        );
        let moved = reference
            .intensity
            .iter()
            .zip(&own)
            .filter(|(a, b)| a != b)
            .count();
        assert!(moved > own.len() / 2, "{moved} of {}", own.len());
    }
}
