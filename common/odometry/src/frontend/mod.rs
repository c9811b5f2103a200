//! The whole front end in one process: ORB points, lines, planes and Manhattan axes of a
//! frame, chained as the points / lines / planes services chain them in the pipeline.
//! This is the `inline` mode's front end and the tests' way to make [`FrameFeatures`].

pub(crate) mod features;

use crate::depth::grid::DepthGrid;
use crate::frontend::features::{FrameFeatures, FrameSurfaces};
use gfs_core::ImageView;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::FrameId;
use gfs_lines::Line3;
use gfs_lines::extractor::{LineConfig, LineExtractor, LineFeatures};
use gfs_planes::{ManhattanAxes, ManhattanEstimator, Plane, PlaneConfig, PlaneExtractor};
use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures};
use nalgebra::{Rotation3, Vector3};
use std::time::{Duration, Instant};

/// A front-end stage refused its config or a frame (bad sizes).
#[derive(Debug, thiserror::Error)]
pub enum FrontendError {
    /// The ORB extractor refused the config or the frame.
    #[error("points: {0}")]
    Points(String),
    /// The plane extractor refused the config or the frame.
    #[error("planes: {0}")]
    Planes(String),
}

/// Time spent per stage on the last frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrontendTimings {
    /// ORB extraction.
    pub points: Duration,
    /// Line detection, joining, homogenisation, LBD and 3D lines.
    pub lines: Duration,
    /// Plane normals, BFS planes and Manhattan axes.
    pub planes: Duration,
}

/// What [`StructureExtractor::extract`] makes of a frame besides its surfaces.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceRequest<'a> {
    /// The frame's valid 3D lines (camera frame) and the predicted rotation
    /// (`current_from_previous`, which keeps the axes' identity), when the axes are on.
    pub axes_from: Option<(&'a [Line3], Option<&'a Rotation3<f64>>)>,
    /// Whether the surfaces carry the BFS planes (`[tracking] use_planes`).
    pub planes: bool,
    /// Whether the surfaces carry the depth grid, with the gray level of each node's
    /// cell (`[tracking] use_depth_alignment`).
    pub depth: bool,
}

/// Plane normals and the frame's Manhattan axes from its planes and 3D lines (the
/// `planes` stage), with reusable scratch.
pub struct StructureExtractor {
    planes: PlaneExtractor,
    plane_out: Vec<Plane>,
    manhattan: ManhattanEstimator,
    directions: Vec<Vector3<f32>>,
    weights: Vec<f32>,
}

impl StructureExtractor {
    /// The extractor for `config`.
    ///
    /// # Errors
    /// [`FrontendError::Planes`] when the config is invalid.
    pub fn new(config: &PlaneConfig) -> Result<Self, FrontendError> {
        Ok(Self {
            planes: PlaneExtractor::new(config)
                .map_err(|e| FrontendError::Planes(e.to_string()))?,
            manhattan: ManhattanEstimator::new(config)
                .map_err(|e| FrontendError::Planes(e.to_string()))?,
            plane_out: Vec::new(),
            directions: Vec::new(),
            weights: Vec::new(),
        })
    }

    /// The last frame's BFS planes.
    pub fn planes(&self) -> &[Plane] {
        &self.plane_out
    }

    /// The frame's surfaces into `out` (its buffers reused; what `request` asks for, the
    /// rest cleared) and its Manhattan axes when `request` asks for them.
    ///
    /// # Errors
    /// [`FrontendError::Planes`] when the depth image does not have the camera's size.
    pub fn extract(
        &mut self,
        gray: &ImageView<'_, u8>,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
        request: &SurfaceRequest<'_>,
        out: &mut FrameSurfaces,
    ) -> Result<Option<ManhattanAxes>, FrontendError> {
        self.planes
            .extract(depth, camera, &mut self.plane_out)
            .map_err(|e| FrontendError::Planes(e.to_string()))?;
        let axes = request
            .axes_from
            .and_then(|(lines, rotation)| self.estimate_axes(lines, rotation));
        self.surfaces(request.planes, request.depth, out);
        if request.depth {
            out.depth
                .sample_intensity(gray, DepthGrid::INTENSITY_CELL_PX);
        }
        Ok(axes)
    }

    /// The last frame's planes and depth grid (every [`DEPTH_GRID_STEP`]-th node of the
    /// normal grid, without intensities), each when asked for, into `out` (its buffers
    /// reused).
    pub fn surfaces(&self, planes: bool, depth: bool, out: &mut FrameSurfaces) {
        out.planes.clear();
        if planes {
            out.planes.extend_from_slice(&self.plane_out);
        }
        if depth {
            out.depth.sample(self.planes.normals(), DEPTH_GRID_STEP);
        } else {
            out.depth = DepthGrid::default();
        }
    }

    /// The axes the next frame's are labelled against (the estimator's history).
    pub fn previous_axes(&self) -> Option<&Rotation3<f64>> {
        self.manhattan.previous()
    }

    /// Resumes with the history of a checkpoint.
    pub fn restore_previous_axes(&mut self, previous: Option<Rotation3<f64>>) {
        self.manhattan.restore(previous);
    }

    /// The Manhattan axes of the frame whose surfaces were extracted last, from its
    /// planes and its valid 3D lines (camera frame); `predicted_rotation`
    /// (`current_from_previous`) keeps the axes' identity.
    fn estimate_axes(
        &mut self,
        lines3d: &[Line3],
        predicted_rotation: Option<&Rotation3<f64>>,
    ) -> Option<ManhattanAxes> {
        self.directions.clear();
        self.weights.clear();
        for l in lines3d.iter().filter(|l| l.is_valid()) {
            let d = Vector3::from(l.end) - Vector3::from(l.start);
            self.weights.push(d.norm());
            self.directions.push(d);
        }
        self.manhattan.estimate(
            &self.plane_out,
            &self.directions,
            &self.weights,
            predicted_rotation,
        )
    }
}

/// Sub-sampling of the plane stage's normal grid (4 px) kept for the depth alignment:
/// an 8 px grid.
pub const DEPTH_GRID_STEP: usize = 2;

/// Points, lines and planes extractors with their reusable scratch.
pub struct Frontend {
    camera: PinholeCamera,
    use_lines: bool,
    use_manhattan: bool,
    keep_depth: bool,
    keep_planes: bool,
    orb: OrbExtractor,
    orb_out: OrbFeatures,
    lines: LineExtractor,
    line_out: LineFeatures,
    structure: StructureExtractor,
    timings: FrontendTimings,
}

impl Frontend {
    /// Builds the three extractors. `use_lines` / `use_manhattan` are the ablation
    /// switches: lines switched off are not extracted, axes switched off are not
    /// estimated (the surfaces still are when the depth grid or the planes are kept).
    ///
    /// # Errors
    /// [`FrontendError`] when a stage's config is invalid.
    pub fn new(
        camera: PinholeCamera,
        points: &OrbConfig,
        lines: &LineConfig,
        planes: &PlaneConfig,
        use_lines: bool,
        use_manhattan: bool,
    ) -> Result<Self, FrontendError> {
        Ok(Self {
            orb: OrbExtractor::new(points.clone())
                .map_err(|e| FrontendError::Points(e.to_string()))?,
            lines: LineExtractor::new(lines.clone()),
            structure: StructureExtractor::new(planes)?,
            orb_out: OrbFeatures::default(),
            line_out: LineFeatures::default(),
            timings: FrontendTimings::default(),
            camera,
            use_lines,
            use_manhattan,
            keep_depth: false,
            keep_planes: false,
        })
    }

    /// Whether the frames carry their depth grid ([`FrameFeatures::depth`], for
    /// `[tracking] use_depth_alignment`), with or without the Manhattan axes.
    /// Off by default: the grid is 115 kB a frame.
    pub fn set_keep_depth(&mut self, keep: bool) {
        self.keep_depth = keep;
    }

    /// Whether the frames carry their BFS planes ([`FrameFeatures::planes`], for
    /// `[tracking] use_planes`), with or without the Manhattan axes.
    pub fn set_keep_planes(&mut self, keep: bool) {
        self.keep_planes = keep;
    }

    /// Stage timings of the last [`Self::extract`].
    pub fn timings(&self) -> &FrontendTimings {
        &self.timings
    }

    /// Extracts the features of one undistorted frame. `predicted_rotation`
    /// (`current_from_previous`) keeps the Manhattan axes' identity across frames.
    ///
    /// # Errors
    /// [`FrontendError`] when the images do not have the camera's size.
    pub fn extract(
        &mut self,
        id: FrameId,
        timestamp: gfs_core::stamp::Stamp,
        gray: ImageView<'_, u8>,
        depth: ImageView<'_, f32>,
        predicted_rotation: Option<&Rotation3<f64>>,
    ) -> Result<FrameFeatures, FrontendError> {
        let start = Instant::now();
        self.orb
            .extract(gray, Some(depth), &mut self.orb_out)
            .map_err(|e| FrontendError::Points(e.to_string()))?;
        let points_done = Instant::now();
        self.line_out.clear();
        if self.use_lines {
            self.lines
                .extract(&gray, &depth, &self.camera, &mut self.line_out);
        }
        let lines_done = Instant::now();
        let mut manhattan = None;
        let mut surfaces = FrameSurfaces::default();
        // The surfaces serve the axes, the depth alignment and the planes, each
        // switched on its own.
        if self.use_manhattan || self.keep_depth || self.keep_planes {
            let request = SurfaceRequest {
                axes_from: self
                    .use_manhattan
                    .then_some((&self.line_out.lines3d, predicted_rotation)),
                planes: self.keep_planes,
                depth: self.keep_depth,
            };
            manhattan =
                self.structure
                    .extract(&gray, &depth, &self.camera, &request, &mut surfaces)?;
        }
        self.timings = FrontendTimings {
            points: points_done - start,
            lines: lines_done - points_done,
            planes: lines_done.elapsed(),
        };
        Ok(FrameFeatures {
            id,
            timestamp,
            keypoints: self.orb_out.keypoints.clone(),
            point_descriptors: self.orb_out.descriptors.clone(),
            lines: self.line_out.lines.clone(),
            line_descriptors: self.line_out.descriptors.clone(),
            lines3d: self.line_out.lines3d.clone(),
            manhattan,
            planes: surfaces.planes,
            depth: surfaces.depth,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::Image;

    /// A camera facing a wall 2 m away, with a floor 0.8 m below it and a side wall
    /// 1 m to its left: three perpendicular planes, no texture.
    fn corner(camera: &PinholeCamera) -> (Image<u8>, Image<f32>) {
        let (w, h) = (camera.width, camera.height);
        let mut depth: Image<f32> = Image::new(w, h);
        for v in 0..h {
            for u in 0..w {
                let x = (u as f64 - camera.cx) / camera.fx;
                let y = (v as f64 - camera.cy) / camera.fy;
                let mut z: f64 = 2.0;
                if y > 0.0 {
                    z = z.min(0.8 / y);
                }
                if x < 0.0 {
                    z = z.min(-1.0 / x);
                }
                depth.set(u, v, z as f32);
            }
        }
        let mut gray: Image<u8> = Image::new(w, h);
        gray.fill(128);
        (gray, depth)
    }

    fn extract(use_manhattan: bool) -> FrameFeatures {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        let (gray, depth) = corner(&camera);
        let mut frontend = Frontend::new(
            camera,
            &OrbConfig::default(),
            &LineConfig::default(),
            &PlaneConfig::default(),
            false,
            use_manhattan,
        )
        .unwrap();
        frontend.set_keep_depth(true);
        frontend.set_keep_planes(true);
        frontend
            .extract(
                FrameId(0),
                Default::default(),
                gray.view(),
                depth.view(),
                None,
            )
            .unwrap()
    }

    #[test]
    fn the_depth_and_plane_terms_get_their_surfaces_without_the_manhattan_axes() {
        let with_axes = extract(true);
        let without = extract(false);
        assert!(with_axes.manhattan.is_some());
        assert!(without.manhattan.is_none());
        assert_eq!(without.planes.len(), 3);
        assert_eq!(without.planes, with_axes.planes);
        assert!(without.depth.has_depth());
        assert_eq!(without.depth, with_axes.depth);
    }
}
