//! The ray-casting renderer: colour and depth of a pinhole camera looking at a [`Scene`].
//!
//! Per frame, quads facing away from the camera are dropped and the others are binned
//! into 16x16-pixel tiles by their projected bounding box (after clipping at the near
//! plane), so each ray tests only the few quads of its tile. Depth is the exact `z` of
//! the nearest hit at the pixel centre (rays are cast as `(x, y, 1)` in the camera frame,
//! so the ray parameter *is* `z`). Colour is antialiased where it matters: pixels whose
//! 3x3 neighbourhood sees another quad or another texture region (see
//! [`crate::texture`]) are re-sampled on a 3x3 sub-pixel grid, which turns silhouettes,
//! frame borders, grout and glyph strokes into camera-like edges. Shading is view
//! independent (Lambertian sun + ceiling lamp + ambient), so a surface keeps its colour
//! as the camera moves and faces of different orientation differ in brightness.

use crate::scene::Scene;
use crate::sequence::LUMA_WEIGHTS;
use gfs_core::camera::PinholeCamera;
use gfs_core::{DepthImage, RgbImage};
use nalgebra::{Isometry3, Point3, Vector3};

/// Tile edge in pixels for binning quads.
const TILE: usize = 16;
/// Hits closer than this to the camera plane are ignored (metres).
const NEAR: f64 = 0.05;
/// Tolerance on quad bounds so that rays through a shared box edge never leak.
const EDGE_EPS: f64 = 1e-9;
/// "Ambient cube" lighting (brightness of a face by its normal, blended with the squared
/// normal components): `[+x, -x, +y, -y, +z, -z]`. Faces that can meet at a crease
/// (any vertical with any other vertical of the other axis, or with floor / ceiling)
/// differ by at least 0.1, so box edges and room corners show as shading steps.
const AMBIENT_CUBE: [f64; 6] = [0.9, 0.86, 0.76, 0.72, 1.0, 0.62];
/// Overall scale of the ambient cube, leaving headroom for the lamp.
const AMBIENT_GAIN: f64 = 0.82;
/// Strength and falloff distance (metres) of the ceiling lamp of the scene.
const LAMP_GAIN: f64 = 0.25;
const LAMP_FALLOFF: f64 = 2.5;
/// Sub-pixel offsets of the antialiasing grid (3x3 samples).
const AA_OFFSETS: [f64; 3] = [-1.0 / 3.0, 0.0, 1.0 / 3.0];

/// Linear colour, depth, incidence and region key of every pixel of one view: what the
/// noise model needs on top of the clean images.
#[derive(Clone, Debug, Default)]
pub(crate) struct RenderBuffers {
    pub width: usize,
    pub height: usize,
    /// Colour in [0, 1] (may exceed 1 on bright lit surfaces; clamped on output).
    pub colour: Vec<[f32; 3]>,
    /// `z` of the nearest hit, metres; 0 where no surface is hit.
    pub depth: Vec<f32>,
    /// Cosine of the angle between the ray and the surface normal (0 where no hit).
    pub cos_incidence: Vec<f32>,
    key: Vec<u64>,
}

impl RenderBuffers {
    fn resize(&mut self, width: usize, height: usize) {
        let n = width * height;
        self.width = width;
        self.height = height;
        self.colour.resize(n, [0.0; 3]);
        self.depth.resize(n, 0.0);
        self.cos_incidence.resize(n, 0.0);
        self.key.resize(n, 0);
    }
}

/// Renders the clean (noise-free) colour and exact depth of `scene` seen by `camera` at
/// pose `world_from_camera`. `rgb` and `depth` are resized to the camera's size; depth is
/// `z` along the optical axis in metres, 0 where nothing is hit.
///
/// ```
/// use gfs_synth::{render_view, Scene, SceneKind};
/// use gfs_core::{camera::PinholeCamera, DepthImage, RgbImage};
/// use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
/// let scene = Scene::new(SceneKind::Room, 1);
/// let camera = PinholeCamera::new(40.0, 40.0, 39.5, 29.5, 80, 60);
/// // Camera at (2, 2.5, 1.5) looking along -y (camera z) with y down (world -z).
/// let look = UnitQuaternion::from_basis_unchecked(&[-Vector3::x(), -Vector3::z(), -Vector3::y()]);
/// let pose = Isometry3::from_parts(Translation3::new(2.0, 2.5, 1.5), look);
/// let (mut rgb, mut depth) = (RgbImage::new(0, 0), DepthImage::new(0, 0));
/// render_view(&scene, &camera, &pose, &mut rgb, &mut depth);
/// // The brick wall is the plane y = 0: 2.5 m ahead, z constant over it.
/// assert!((depth.get(40, 30).unwrap() - 2.5).abs() < 1e-6);
/// assert_eq!(rgb.width(), 80);
/// ```
pub fn render_view(
    scene: &Scene,
    camera: &PinholeCamera,
    world_from_camera: &Isometry3<f64>,
    rgb: &mut RgbImage,
    depth: &mut DepthImage,
) {
    let mut buffers = RenderBuffers::default();
    render_into(scene, camera, world_from_camera, &mut buffers);
    rgb.resize(camera.width, camera.height);
    depth.resize(camera.width, camera.height);
    for (out, c) in rgb.as_mut_slice().iter_mut().zip(&buffers.colour) {
        *out = c.map(to_u8);
    }
    depth.as_mut_slice().copy_from_slice(&buffers.depth);
}

/// Renders the clean luma (BT.601 on a 0-255 scale, neither rounded nor clamped, at an
/// exposure gain of one) and the exact depth of `scene` seen from `world_from_camera`,
/// resized to the camera: the unquantised images whose derivatives bound what a view can
/// tell about its pose (8-bit steps would hide a faint paint's gradient).
///
/// ```
/// use gfs_synth::{luma, render_luma_view, render_view, Scene, SceneKind};
/// use gfs_core::{camera::PinholeCamera, DepthImage, RgbImage};
/// use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
/// let scene = Scene::new(SceneKind::LowTexture, 1);
/// let camera = PinholeCamera::new(40.0, 40.0, 39.5, 29.5, 80, 60);
/// let look = UnitQuaternion::from_basis_unchecked(&[-Vector3::x(), -Vector3::z(), -Vector3::y()]);
/// let pose = Isometry3::from_parts(Translation3::new(2.0, 2.5, 1.5), look);
/// let (mut rgb, mut depth) = (RgbImage::new(0, 0), DepthImage::new(0, 0));
/// render_view(&scene, &camera, &pose, &mut rgb, &mut depth);
/// let (mut fine, mut exact) = (Vec::new(), Vec::new());
/// render_luma_view(&scene, &camera, &pose, &mut fine, &mut exact);
/// assert_eq!(exact.as_slice(), depth.as_slice());
/// // The 8-bit image is the same luma rounded, channel by channel and again as gray
/// // (where no channel saturates).
/// for (f, c) in fine.iter().zip(rgb.as_slice()).filter(|(_, c)| c.iter().all(|&v| v < 255)) {
///     assert!((f - f32::from(luma(*c))).abs() <= 1.0, "{f} against {c:?}");
/// }
/// ```
pub fn render_luma_view(
    scene: &Scene,
    camera: &PinholeCamera,
    world_from_camera: &Isometry3<f64>,
    luma: &mut Vec<f32>,
    depth: &mut Vec<f32>,
) {
    let mut buffers = RenderBuffers::default();
    render_into(scene, camera, world_from_camera, &mut buffers);
    luma.clear();
    let [r, g, b] = LUMA_WEIGHTS.map(|w| w as f32);
    luma.extend(
        buffers
            .colour
            .iter()
            .map(|c| 255.0 * (r * c[0] + g * c[1] + b * c[2])),
    );
    depth.clear();
    depth.extend_from_slice(&buffers.depth);
}

/// A [0, 1] value to 8 bits, rounded and clamped.
#[inline]
pub(crate) fn to_u8(v: f32) -> u8 {
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Renders into reusable buffers (pass 1: centre rays; pass 2: antialiasing), one ray
/// per pixel of `camera`'s image.
pub(crate) fn render_into(
    scene: &Scene,
    camera: &PinholeCamera,
    world_from_camera: &Isometry3<f64>,
    out: &mut RenderBuffers,
) {
    render_rays_into(scene, camera, world_from_camera, None, out);
}

/// The rays of a lens: the image is `width x height`, and its pixel `i` looks along the
/// ray through `positions[i]` of the ideal camera the view is cast through.
pub(crate) struct Rays<'a> {
    pub width: usize,
    pub height: usize,
    pub positions: &'a [[f32; 2]],
}

/// [`render_into`] with the rays of `rays` when given (an image through a lens).
pub(crate) fn render_rays_into(
    scene: &Scene,
    camera: &PinholeCamera,
    world_from_camera: &Isometry3<f64>,
    rays: Option<&Rays<'_>>,
    out: &mut RenderBuffers,
) {
    let (w, h) = rays.map_or((camera.width, camera.height), |r| (r.width, r.height));
    out.resize(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let view = View::new(scene, camera, world_from_camera);
    // Where pixel (x, y) looks, in the view's pixels.
    let ray = |x: usize, y: usize| match rays {
        Some(r) => {
            let [u, v] = r.positions[y * w + x];
            (f64::from(u), f64::from(v))
        }
        None => (x as f64, y as f64),
    };
    let rows = ROWS_PER_TASK * w;
    let tasks: Vec<_> = out
        .colour
        .chunks_mut(rows)
        .zip(out.depth.chunks_mut(rows))
        .zip(out.cos_incidence.chunks_mut(rows))
        .zip(out.key.chunks_mut(rows))
        .enumerate()
        .collect();
    for_each_parallel(tasks, |(k, (((colour, depth), cos), key))| {
        for (i, px) in colour.iter_mut().enumerate() {
            let (x, y) = (i % w, k * ROWS_PER_TASK + i / w);
            let (u, v) = ray(x, y);
            let s = view.sample(u, v);
            *px = s.colour;
            depth[i] = s.depth;
            cos[i] = s.cos;
            key[i] = s.key;
        }
    });
    let keys = &out.key;
    let tasks: Vec<_> = out.colour.chunks_mut(rows).enumerate().collect();
    for_each_parallel(tasks, |(k, colour)| {
        for (i, px) in colour.iter_mut().enumerate() {
            let (x, y) = (i % w, k * ROWS_PER_TASK + i / w);
            if needs_antialiasing(keys, w, h, x, y) {
                let (u, v) = ray(x, y);
                *px = view.supersample(u, v, *px);
            }
        }
    });
}

/// Rows per parallel task: small enough to balance cheap (ceiling) and expensive
/// (poster) rows across threads, large enough to amortise the task.
const ROWS_PER_TASK: usize = 8;

/// True when a pixel of the 3x3 neighbourhood of (`x`, `y`) has another region key.
fn needs_antialiasing(keys: &[u64], w: usize, h: usize, x: usize, y: usize) -> bool {
    let k = keys[y * w + x];
    let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
    for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
        let row = &keys[yy * w..yy * w + w];
        for &other in &row[x0..=x1] {
            if other != k {
                return true;
            }
        }
    }
    false
}

/// Runs `f` on every item, spread round-robin over the available cores.
pub(crate) fn for_each_parallel<T: Send>(items: Vec<T>, f: impl Fn(T) + Sync) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len());
    if threads <= 1 {
        items.into_iter().for_each(f);
        return;
    }
    let mut lists: Vec<Vec<T>> = (0..threads).map(|_| Vec::new()).collect();
    for (k, item) in items.into_iter().enumerate() {
        lists[k % threads].push(item);
    }
    let f = &f;
    std::thread::scope(|scope| {
        for list in lists {
            scope.spawn(move || list.into_iter().for_each(f));
        }
    });
}

/// A front-facing quad in the camera frame, with what the ray test needs precomputed.
struct CamQuad {
    normal: Vector3<f64>,
    /// `normal . origin`, negative for a front-facing quad.
    normal_dot_origin: f64,
    axis_u: Vector3<f64>,
    axis_v: Vector3<f64>,
    origin_u: f64,
    origin_v: f64,
    size: [f64; 2],
    /// View-independent ambient-cube term.
    ambient: f64,
    texture: usize,
    index: u32,
}

/// What one ray sees.
struct Sample {
    colour: [f32; 3],
    depth: f32,
    cos: f32,
    key: u64,
}

/// One camera pose's visible quads and tile bins.
struct View<'a> {
    scene: &'a Scene,
    camera: PinholeCamera,
    quads: Vec<CamQuad>,
    tiles: Vec<Vec<u32>>,
    tiles_x: usize,
    lamp_in_camera: Point3<f64>,
}

impl<'a> View<'a> {
    fn new(scene: &'a Scene, camera: &PinholeCamera, world_from_camera: &Isometry3<f64>) -> Self {
        let camera_from_world = world_from_camera.inverse();
        let centre = Point3::from(world_from_camera.translation.vector);
        let tiles_x = camera.width.div_ceil(TILE);
        let tiles_y = camera.height.div_ceil(TILE);
        let mut tiles = vec![Vec::new(); tiles_x * tiles_y];
        let mut quads = Vec::new();
        for (index, q) in scene.quads.iter().enumerate() {
            let n_world = q.normal();
            if n_world.dot(&(centre - q.origin)) <= 0.0 {
                continue; // seen from behind: never visible in a closed scene
            }
            let Some([u0, v0, u1, v1]) = projected_bounds(camera, &camera_from_world, &q.corners())
            else {
                continue;
            };
            let origin = camera_from_world * q.origin;
            let normal = camera_from_world * n_world;
            let axis_u = camera_from_world * q.axis_u;
            let axis_v = camera_from_world * q.axis_v;
            let local = quads.len() as u32;
            quads.push(CamQuad {
                normal,
                normal_dot_origin: normal.dot(&origin.coords),
                axis_u,
                axis_v,
                origin_u: origin.coords.dot(&axis_u),
                origin_v: origin.coords.dot(&axis_v),
                size: q.size,
                ambient: ambient_cube(&n_world),
                texture: q.texture,
                index: index as u32,
            });
            // One pixel of margin covers the antialiasing sub-samples.
            let clamp_x = |v: f64| (v.max(0.0) as usize).min(camera.width - 1) / TILE;
            let clamp_y = |v: f64| (v.max(0.0) as usize).min(camera.height - 1) / TILE;
            for ty in clamp_y(v0 - 1.0)..=clamp_y(v1 + 1.0) {
                for tx in clamp_x(u0 - 1.0)..=clamp_x(u1 + 1.0) {
                    tiles[ty * tiles_x + tx].push(local);
                }
            }
        }
        Self {
            scene,
            camera: *camera,
            quads,
            tiles,
            tiles_x,
            lamp_in_camera: camera_from_world * scene.lamp,
        }
    }

    /// Traces the ray through (`u`, `v`) with the quads of the tile of the pixel nearest
    /// to it.
    fn sample(&self, u: f64, v: f64) -> Sample {
        let x = (u.round().max(0.0) as usize).min(self.camera.width - 1);
        let y = (v.round().max(0.0) as usize).min(self.camera.height - 1);
        let tile = &self.tiles[(y / TILE) * self.tiles_x + x / TILE];
        let d = Vector3::new(
            (u - self.camera.cx) / self.camera.fx,
            (v - self.camera.cy) / self.camera.fy,
            1.0,
        );
        let mut best: Option<(&CamQuad, f64, f64, f64)> = None;
        let mut best_z = f64::INFINITY;
        for &i in tile {
            let q = &self.quads[i as usize];
            let denom = q.normal.dot(&d);
            if denom >= 0.0 {
                continue;
            }
            let z = q.normal_dot_origin / denom;
            if z >= best_z || z < NEAR {
                continue;
            }
            let a = z * d.dot(&q.axis_u) - q.origin_u;
            let b = z * d.dot(&q.axis_v) - q.origin_v;
            if a < -EDGE_EPS
                || b < -EDGE_EPS
                || a > q.size[0] + EDGE_EPS
                || b > q.size[1] + EDGE_EPS
            {
                continue;
            }
            best_z = z;
            best = Some((q, z, a, b));
        }
        let Some((q, z, a, b)) = best else {
            return Sample {
                colour: [0.0; 3],
                depth: 0.0,
                cos: 0.0,
                key: 0,
            };
        };
        let (texel, region) =
            self.scene.textures[q.texture].sample(a.clamp(0.0, q.size[0]), b.clamp(0.0, q.size[1]));
        let to_lamp = self.lamp_in_camera - Point3::from(d * z);
        let dist2 = to_lamp.norm_squared();
        let lamp = (q.normal.dot(&to_lamp) / dist2.sqrt()).max(0.0)
            / (1.0 + dist2 / (LAMP_FALLOFF * LAMP_FALLOFF));
        let shade = (q.ambient + LAMP_GAIN * lamp) as f32;
        Sample {
            colour: texel.map(|c| c * shade),
            depth: z as f32,
            cos: (-q.normal.dot(&d) / d.norm()) as f32,
            key: (u64::from(q.index) + 1) << 32 | u64::from(region),
        }
    }

    /// Mean colour of the 3x3 sub-pixel grid around (`u`, `v`); `centre` is the colour
    /// already traced there.
    fn supersample(&self, u: f64, v: f64, centre: [f32; 3]) -> [f32; 3] {
        let mut sum = centre;
        for dy in AA_OFFSETS {
            for dx in AA_OFFSETS {
                if dx == 0.0 && dy == 0.0 {
                    continue;
                }
                let c = self.sample(u + dx, v + dy).colour;
                for k in 0..3 {
                    sum[k] += c[k];
                }
            }
        }
        sum.map(|c| c / 9.0)
    }
}

/// Brightness of a face with unit normal `n` under [`AMBIENT_CUBE`].
fn ambient_cube(n: &Vector3<f64>) -> f64 {
    let mut b = 0.0;
    for k in 0..3 {
        let side = if n[k] >= 0.0 { 2 * k } else { 2 * k + 1 };
        b += n[k] * n[k] * AMBIENT_CUBE[side];
    }
    AMBIENT_GAIN * b
}

/// Pixel bounding box `[u0, v0, u1, v1]` of a polygon after clipping it at the near
/// plane, or `None` when it lies behind the camera or outside the image.
fn projected_bounds(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    corners: &[Point3<f64>; 4],
) -> Option<[f64; 4]> {
    let pts: Vec<Point3<f64>> = corners.iter().map(|p| camera_from_world * p).collect();
    let mut bounds = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut extend = |p: &Point3<f64>| {
        let u = camera.fx * p.x / p.z + camera.cx;
        let v = camera.fy * p.y / p.z + camera.cy;
        bounds = [
            bounds[0].min(u),
            bounds[1].min(v),
            bounds[2].max(u),
            bounds[3].max(v),
        ];
    };
    // Sutherland-Hodgman against z >= NEAR, one plane: keep inside vertices and the
    // crossing points of edges that straddle it.
    for k in 0..pts.len() {
        let (p, q) = (&pts[k], &pts[(k + 1) % pts.len()]);
        if p.z >= NEAR {
            extend(p);
        }
        if (p.z >= NEAR) != (q.z >= NEAR) {
            let s = (NEAR - p.z) / (q.z - p.z);
            extend(&(p + (q - p) * s));
        }
    }
    let (w, h) = (camera.width as f64, camera.height as f64);
    let visible = bounds[0] <= w && bounds[1] <= h && bounds[2] >= -1.0 && bounds[3] >= -1.0;
    visible.then_some(bounds)
}
