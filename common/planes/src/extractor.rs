//! BFS plane extraction (paper Sec. III-A, Algorithm 1, `BFS` and `NormalExtraction`):
//! breadth-first region growing over the normal grid, then one plane per large region.

use crate::config::PlaneConfig;
use crate::error::PlaneError;
use crate::normals::NormalEstimator;
use gfs_core::ImageView;
use gfs_core::camera::PinholeCamera;
use std::time::{Duration, Instant};

/// A plane seen in one frame, in the camera frame: `normal . p + offset = 0` for its
/// points `p`. Plain data so it can travel in a zero-copy message.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plane {
    /// Unit normal (camera frame), pointing towards the camera: the normalised mean of
    /// the region's pixel normals.
    pub normal: [f32; 3],
    /// Distance of the plane from the camera centre (m), `-normal . centroid`;
    /// positive because the normal faces the camera.
    pub offset: f32,
    /// Image pixels the plane covers (grid nodes x stride^2), stride-independent.
    pub pixels: u32,
    /// Mean of the region's node points (camera frame, m).
    pub centroid: [f32; 3],
}

/// Wall-clock time of the steps of the last [`PlaneExtractor::extract`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtractTimings {
    /// Back-projection and pixel normals.
    pub normals: Duration,
    /// BFS region growing, merging and plane fitting.
    pub regions: Duration,
}

/// Grid label of a node no region has taken yet.
const UNVISITED: u32 = u32::MAX - 1;
/// Grid label of a node without a normal during region growing.
const NO_NORMAL: u32 = u32::MAX;
/// Grid label of a node outside every output plane, in [`PlaneExtractor::labels`].
pub const NO_PLANE: u32 = u32::MAX;

/// Running sums of one BFS region.
#[derive(Clone, Copy, Debug)]
struct Region {
    normal_sum: [f32; 3],
    point_sum: [f32; 3],
    nodes: u32,
    /// Index of the region this one was merged into (itself when a root).
    parent: u32,
    /// Index of the output plane, or [`NO_PLANE`].
    plane: u32,
}

/// Extracts planes from depth frames, reusing its grid, label and queue buffers.
///
/// Growth rule (why two angle tests): a node joins its region when its normal is within
/// `neighbour_angle_deg` of the node it is reached from (Algorithm 1's adjacent-pixel
/// test, which stops at creases between walls) **and** within `region_angle_deg` of the
/// region's running mean normal, which stops the slow drift that the neighbour test
/// alone allows around curved surfaces. Regions are not tied to a fixed grid of cells
/// (unlike integral-image methods): any connected shape is one plane.
#[derive(Clone, Debug)]
pub struct PlaneExtractor {
    config: PlaneConfig,
    cos_neighbour: f32,
    cos_region: f32,
    cos_merge: f32,
    normals: NormalEstimator,
    labels: Vec<u32>,
    queue: Vec<u32>,
    regions: Vec<Region>,
    /// Indices of the regions large enough to be planes (merge and output order).
    large: Vec<usize>,
    timings: ExtractTimings,
}

impl PlaneExtractor {
    /// An extractor with the given parameters.
    ///
    /// # Errors
    /// [`PlaneError::InvalidConfig`] naming the first invalid field.
    pub fn new(config: &PlaneConfig) -> Result<Self, PlaneError> {
        config.validate()?;
        Ok(Self {
            config: config.clone(),
            cos_neighbour: config.neighbour_angle_deg.to_radians().cos(),
            cos_region: config.region_angle_deg.to_radians().cos(),
            cos_merge: config.merge_angle_deg.to_radians().cos(),
            normals: NormalEstimator::new(
                config.stride,
                config.average_blocks,
                config.max_depth_jump_per_px,
            ),
            labels: Vec::new(),
            queue: Vec::new(),
            regions: Vec::new(),
            large: Vec::new(),
            timings: ExtractTimings::default(),
        })
    }

    /// Replaces `planes` with the planes of `depth` (metres, 0.0 = missing), largest
    /// first. A frame with no valid depth, or too small for the grid, gives no plane.
    ///
    /// # Errors
    /// [`PlaneError::SizeMismatch`] when `depth` is not the camera's size.
    pub fn extract(
        &mut self,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
        planes: &mut Vec<Plane>,
    ) -> Result<(), PlaneError> {
        planes.clear();
        let start = Instant::now();
        self.normals.compute(depth, camera)?;
        let grown = Instant::now();
        self.grow_regions();
        self.merge_regions();
        self.emit_planes(planes);
        self.timings = ExtractTimings {
            normals: grown - start,
            regions: grown.elapsed(),
        };
        Ok(())
    }

    /// Algorithm 1, `NormalExtraction`: every node with a normal that no region has
    /// taken seeds a breadth-first search (raster order).
    fn grow_regions(&mut self) {
        let w = self.normals.grid_width();
        let normals = self.normals.normals();
        let points = self.normals.points();
        // Nodes without a normal start out taken, so one label test rejects both.
        self.labels.clear();
        self.labels.extend(
            normals
                .iter()
                .map(|&n| if has_normal(n) { UNVISITED } else { NO_NORMAL }),
        );
        self.regions.clear();
        for seed in 0..normals.len() {
            if self.labels[seed] != UNVISITED {
                continue;
            }
            let id = self.regions.len() as u32;
            let mut region = Region {
                normal_sum: normals[seed],
                point_sum: points[seed],
                nodes: 1,
                parent: id,
                plane: NO_PLANE,
            };
            self.labels[seed] = id;
            self.queue.clear();
            self.queue.push(seed as u32);
            let mut head = 0;
            while let Some(&node) = self.queue.get(head) {
                head += 1;
                let c = node as usize;
                let nc = normals[c];
                let s = region.normal_sum;
                let region_limit = self.cos_region * dot(s, s).sqrt();
                // Nodes with a normal are interior (the border has none), so the four
                // neighbours are inside the grid.
                for q in [c - 1, c + 1, c - w, c + w] {
                    let nq = normals[q];
                    if self.labels[q] != UNVISITED
                        || dot(nq, nc) < self.cos_neighbour
                        || dot(nq, s) < region_limit
                    {
                        continue;
                    }
                    self.labels[q] = id;
                    self.queue.push(q as u32);
                    add(&mut region.normal_sum, nq);
                    add(&mut region.point_sum, points[q]);
                    region.nodes += 1;
                }
            }
            self.regions.push(region);
        }
    }

    /// Smallest region kept as a plane, in grid nodes.
    fn min_nodes(&self) -> u32 {
        let area = (self.config.stride * self.config.stride) as u32;
        self.config.min_plane_pixels.div_ceil(area).max(1)
    }

    /// Merges large regions with the same normal and offset (a wall cut in two by an
    /// object in front of it), by union into the larger one.
    fn merge_regions(&mut self) {
        if self.config.merge_angle_deg <= 0.0 {
            return;
        }
        let min_nodes = self.min_nodes();
        let mut large = std::mem::take(&mut self.large);
        large.clear();
        large.extend((0..self.regions.len()).filter(|&i| self.regions[i].nodes >= min_nodes));
        for (k, &a) in large.iter().enumerate() {
            for &b in &large[k + 1..] {
                let (ra, rb) = (self.root(a), self.root(b));
                if ra == rb {
                    continue;
                }
                let (pa, pb) = (fit(&self.regions[ra]), fit(&self.regions[rb]));
                let same_offset = (pa.offset - pb.offset).abs()
                    <= self.config.merge_offset_ratio * pa.offset.abs().max(pb.offset.abs());
                if dot(pa.normal, pb.normal) >= self.cos_merge && same_offset {
                    let (big, small) = if self.regions[ra].nodes >= self.regions[rb].nodes {
                        (ra, rb)
                    } else {
                        (rb, ra)
                    };
                    let s = self.regions[small];
                    let r = &mut self.regions[big];
                    add(&mut r.normal_sum, s.normal_sum);
                    add(&mut r.point_sum, s.point_sum);
                    r.nodes += s.nodes;
                    self.regions[small].parent = big as u32;
                }
            }
        }
        self.large = large;
    }

    /// The root of a region's merge tree.
    fn root(&self, mut i: usize) -> usize {
        while self.regions[i].parent as usize != i {
            i = self.regions[i].parent as usize;
        }
        i
    }

    /// Writes one plane per large root region, largest first, and relabels the grid
    /// with plane indices.
    fn emit_planes(&mut self, planes: &mut Vec<Plane>) {
        let min_nodes = self.min_nodes();
        let area = (self.config.stride * self.config.stride) as u32;
        let mut roots = std::mem::take(&mut self.large);
        roots.clear();
        roots.extend((0..self.regions.len()).filter(|&i| {
            self.regions[i].parent as usize == i && self.regions[i].nodes >= min_nodes
        }));
        roots.sort_by_key(|&i| std::cmp::Reverse(self.regions[i].nodes));
        for &r in &roots {
            let mut plane = fit(&self.regions[r]);
            plane.pixels = self.regions[r].nodes.saturating_mul(area);
            self.regions[r].plane = planes.len() as u32;
            planes.push(plane);
        }
        self.large = roots;
        // Merged regions take their root's plane (roots come first in no order, so
        // resolve each one through its root).
        for i in 0..self.regions.len() {
            let root = self.root(i);
            self.regions[i].plane = self.regions[root].plane;
        }
        let regions = &self.regions;
        for label in &mut self.labels {
            *label = match *label {
                UNVISITED | NO_NORMAL => NO_PLANE,
                region => regions[region as usize].plane,
            };
        }
    }

    /// Per grid node (row-major, [`Self::grid_size`]), the index in the last `planes`
    /// output of the plane it belongs to, or [`NO_PLANE`].
    pub fn labels(&self) -> &[u32] {
        &self.labels
    }

    /// Grid (columns, rows) of the last frame.
    pub fn grid_size(&self) -> (usize, usize) {
        (self.normals.grid_width(), self.normals.grid_height())
    }

    /// The pixel normals of the last frame.
    pub fn normals(&self) -> &NormalEstimator {
        &self.normals
    }

    /// Step timings of the last [`Self::extract`] call.
    pub fn timings(&self) -> ExtractTimings {
        self.timings
    }
}

/// The plane of a region: normalised mean normal through the mean point.
fn fit(region: &Region) -> Plane {
    let n = region.normal_sum;
    let norm = dot(n, n).sqrt().max(f32::MIN_POSITIVE);
    let normal = [n[0] / norm, n[1] / norm, n[2] / norm];
    let k = 1.0 / region.nodes as f32;
    let centroid = [
        region.point_sum[0] * k,
        region.point_sum[1] * k,
        region.point_sum[2] * k,
    ];
    Plane {
        normal,
        offset: -dot(normal, centroid),
        pixels: region.nodes,
        centroid,
    }
}

/// True for a node with a normal (the grid stores zeros elsewhere).
#[inline]
fn has_normal(n: [f32; 3]) -> bool {
    n != [0.0; 3]
}

#[inline]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn add(a: &mut [f32; 3], b: [f32; 3]) {
    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
}
