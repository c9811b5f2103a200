//! The scene model: textured rectangles ("quads") in the world frame, built from boxes
//! and flat panels, plus the ground truth that tests compare against (planes, straight
//! 3D edges, the Manhattan frame).
//!
//! World frame: z up, the floor at z = 0, walls along the x and y axes, so the world axes
//! *are* the Manhattan frame. Every quad is one-sided: it is seen only from the side its
//! normal points to (walls point into the room, box faces point out), which is all a
//! closed indoor scene needs and lets the renderer drop back faces per frame.

use crate::scenes;
use crate::texture::Texture;
use nalgebra::{Point3, Vector3};
use serde::Deserialize;
use std::fmt;

/// Which procedural scene to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneKind {
    /// A 6 x 5 x 2.7 m textured room: bricks, posters, shelves, tiled floor (default).
    #[default]
    Room,
    /// The same room with plain walls and few edges: the weak-texture case that
    /// structure (lines, planes) must carry.
    LowTexture,
    /// A 14 x 2.2 x 2.6 m corridor with doors on both sides.
    Corridor,
}

impl SceneKind {
    /// All kinds, in CLI order.
    pub const ALL: [SceneKind; 3] = [SceneKind::Room, SceneKind::LowTexture, SceneKind::Corridor];

    /// The CLI / folder name (`room`, `low-texture`, `corridor`).
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Room => "room",
            SceneKind::LowTexture => "low-texture",
            SceneKind::Corridor => "corridor",
        }
    }
}

impl fmt::Display for SceneKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A textured rectangle: `origin + s * axis_u + t * axis_v` for `s in [0, size[0]]`,
/// `t in [0, size[1]]`, visible from the side of `normal = axis_u x axis_v`.
#[derive(Clone, Debug)]
pub struct Quad {
    /// Corner at `(s, t) = (0, 0)`, world frame, metres.
    pub origin: Point3<f64>,
    /// Unit vector of the texture's `s` axis.
    pub axis_u: Vector3<f64>,
    /// Unit vector of the texture's `t` axis (world up on vertical quads).
    pub axis_v: Vector3<f64>,
    /// Extent along `axis_u` and `axis_v`, metres.
    pub size: [f64; 2],
    /// Index into [`Scene::textures`].
    pub texture: usize,
}

impl Quad {
    /// Unit normal, pointing to the visible side.
    pub fn normal(&self) -> Vector3<f64> {
        self.axis_u.cross(&self.axis_v)
    }

    /// The four corners, counter-clockwise seen from the visible side.
    pub fn corners(&self) -> [Point3<f64>; 4] {
        let (du, dv) = (self.axis_u * self.size[0], self.axis_v * self.size[1]);
        [
            self.origin,
            self.origin + du,
            self.origin + du + dv,
            self.origin + dv,
        ]
    }

    /// Euclidean distance from `p` to the rectangle.
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        let d = p - self.origin;
        let s = d.dot(&self.axis_u).clamp(0.0, self.size[0]);
        let t = d.dot(&self.axis_v).clamp(0.0, self.size[1]);
        (self.origin + self.axis_u * s + self.axis_v * t - p).norm()
    }
}

/// The infinite plane of one quad, `normal . x = offset` (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenePlane {
    /// Unit normal, pointing to the visible side.
    pub normal: Vector3<f64>,
    /// Signed distance of the plane from the world origin along `normal`, metres.
    pub offset: f64,
    /// Area of the quad that lies on it, m^2 (to keep only walls, floor and big faces).
    pub area: f64,
    /// Index of the quad in [`Scene::quads`].
    pub quad: usize,
}

/// What makes a [`SceneEdge`] visible.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// Where two faces of different orientation meet (box edges, room corners): a depth
    /// or shading step.
    Crease,
    /// The outline of a flat panel on a wall (poster, door leaf, window pane): a colour
    /// step with (almost) no depth step.
    Border,
}

/// A straight 3D edge of the scene, world frame, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneEdge {
    /// First end point.
    pub a: Point3<f64>,
    /// Second end point.
    pub b: Point3<f64>,
    /// Why it shows in the image.
    pub kind: EdgeKind,
}

/// An axis-aligned box, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Point3<f64>,
    /// Maximum corner.
    pub max: Point3<f64>,
}

impl Aabb {
    /// Centre of the box.
    pub fn center(&self) -> Point3<f64> {
        nalgebra::center(&self.min, &self.max)
    }

    /// Half of the extent along each axis.
    pub fn half_extents(&self) -> Vector3<f64> {
        (self.max - self.min) * 0.5
    }

    /// True when `p` lies inside or on the box.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }
}

/// A procedural indoor scene with its ground truth.
#[derive(Clone, Debug)]
pub struct Scene {
    pub(crate) kind: SceneKind,
    pub(crate) quads: Vec<Quad>,
    pub(crate) textures: Vec<Texture>,
    pub(crate) edges: Vec<SceneEdge>,
    pub(crate) bounds: Aabb,
    pub(crate) free_space: Aabb,
    pub(crate) lamp: Point3<f64>,
    pub(crate) base_yaws: Vec<f64>,
}

impl Scene {
    /// Builds scene `kind`. The geometry is fixed per kind; `seed` varies the texture
    /// content (colours, poster layouts, glyphs, book spines).
    pub fn new(kind: SceneKind, seed: u64) -> Scene {
        scenes::build(kind, seed)
    }

    /// The kind this scene was built as.
    pub fn kind(&self) -> SceneKind {
        self.kind
    }

    /// Every rendered rectangle.
    pub fn quads(&self) -> &[Quad] {
        &self.quads
    }

    /// The textures that [`Quad::texture`] indexes.
    pub fn textures(&self) -> &[Texture] {
        &self.textures
    }

    /// The plane of every quad (walls, floor, ceiling, box faces, panels).
    pub fn planes(&self) -> Vec<ScenePlane> {
        self.quads
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let normal = q.normal();
                ScenePlane {
                    normal,
                    offset: normal.dot(&q.origin.coords),
                    area: q.size[0] * q.size[1],
                    quad: i,
                }
            })
            .collect()
    }

    /// Straight 3D edges: box edges, room corners, panel and frame outlines, poster
    /// blocks. Some are hidden from a given view (behind furniture, inside a cabinet):
    /// check visibility against the rendered depth before expecting them in an image.
    pub fn edges(&self) -> &[SceneEdge] {
        &self.edges
    }

    /// The inside of the room (walls, floor and ceiling bound it).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Where trajectories keep the camera: every point of this box is at least
    /// [`MIN_CLEARANCE`] metres from every surface.
    pub fn free_space(&self) -> Aabb {
        self.free_space
    }

    /// The Manhattan frame: the world axes (x, y along the walls, z up).
    pub fn manhattan_axes(&self) -> [Vector3<f64>; 3] {
        [Vector3::x(), Vector3::y(), Vector3::z()]
    }

    /// Distance from `p` to the nearest surface, metres.
    pub fn distance_to_surfaces(&self, p: &Point3<f64>) -> f64 {
        self.quads
            .iter()
            .map(|q| q.distance(p))
            .fold(f64::INFINITY, f64::min)
    }
}

/// Smallest distance between the camera and any surface along a trajectory, metres.
pub const MIN_CLEARANCE: f64 = 0.5;

/// Accumulates quads, textures and edges while a scene is laid out.
pub(crate) struct SceneBuilder {
    quads: Vec<Quad>,
    textures: Vec<Texture>,
    edges: Vec<SceneEdge>,
}

/// Texture indices of the faces of a box.
#[derive(Clone, Copy)]
pub(crate) struct BoxLook {
    /// The vertical faces other than the front.
    pub sides: usize,
    /// Top and bottom.
    pub top: usize,
    /// The vertical face whose normal is minus the box's (yawed) y axis.
    pub front: usize,
}

impl BoxLook {
    /// The same texture on every face.
    pub fn all(texture: usize) -> Self {
        Self {
            sides: texture,
            top: texture,
            front: texture,
        }
    }
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self {
            quads: Vec::new(),
            textures: Vec::new(),
            edges: Vec::new(),
        }
    }

    /// Registers a texture and returns its index.
    pub fn texture(&mut self, texture: Texture) -> usize {
        self.textures.push(texture);
        self.textures.len() - 1
    }

    /// A quad centred at `center` facing `normal`, `size` metres along its (u, v) axes:
    /// v is world up on vertical quads, u = v x normal, so that u x v = normal.
    pub fn panel(
        &mut self,
        center: Point3<f64>,
        normal: Vector3<f64>,
        size: [f64; 2],
        texture: usize,
        outline: Option<EdgeKind>,
    ) {
        let normal = normal.normalize();
        let axis_v = if normal.z.abs() < 0.5 {
            Vector3::z()
        } else {
            // Horizontal face: u along world x (or y when the normal is tilted toward x).
            let x = if normal.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            normal.cross(&(x - normal * normal.dot(&x)).normalize())
        };
        let axis_u = axis_v.cross(&normal);
        self.panel_with_axes(center, axis_u, axis_v, size, texture, outline);
    }

    /// A quad centred at `center` with explicit unit texture axes.
    pub fn panel_with_axes(
        &mut self,
        center: Point3<f64>,
        axis_u: Vector3<f64>,
        axis_v: Vector3<f64>,
        size: [f64; 2],
        texture: usize,
        outline: Option<EdgeKind>,
    ) {
        let quad = Quad {
            origin: center - axis_u * (0.5 * size[0]) - axis_v * (0.5 * size[1]),
            axis_u,
            axis_v,
            size,
            texture,
        };
        if let Some(kind) = outline {
            let c = quad.corners();
            for k in 0..4 {
                self.edge(c[k], c[(k + 1) % 4], kind);
            }
        }
        self.quads.push(quad);
    }

    /// A straight ground-truth edge.
    pub fn edge(&mut self, a: Point3<f64>, b: Point3<f64>, kind: EdgeKind) {
        self.edges.push(SceneEdge { a, b, kind });
    }

    /// A solid box standing on its bottom face: `center` of the bottom face, `size`
    /// (length along the yawed x, depth along the yawed y, height), `yaw` radians about z.
    /// Adds its six outward faces and twelve edges.
    pub fn solid_box(
        &mut self,
        bottom_center: Point3<f64>,
        size: [f64; 3],
        yaw: f64,
        look: BoxLook,
    ) {
        let axes = [
            Vector3::new(yaw.cos(), yaw.sin(), 0.0),
            Vector3::new(-yaw.sin(), yaw.cos(), 0.0),
            Vector3::z(),
        ];
        let center = bottom_center + Vector3::z() * (0.5 * size[2]);
        for k in 0..3 {
            for sign in [-1.0, 1.0] {
                let normal = axes[k] * sign;
                let face_center = center + normal * (0.5 * size[k]);
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                let texture = match (k, sign > 0.0) {
                    (2, _) => look.top,
                    (1, false) => look.front,
                    _ => look.sides,
                };
                // Vertical faces: u horizontal, v up; top / bottom: u along the box x.
                let (axis_u, axis_v, extent) = if k == 2 {
                    let u = axes[0];
                    (u, normal.cross(&u), [size[0], size[1]])
                } else {
                    let other = if i == 2 { j } else { i };
                    (
                        Vector3::z().cross(&normal),
                        Vector3::z(),
                        [size[other], size[2]],
                    )
                };
                self.panel_with_axes(face_center, axis_u, axis_v, extent, texture, None);
            }
        }
        let corner = |a: f64, b: f64, c: f64| {
            center
                + axes[0] * (a * 0.5 * size[0])
                + axes[1] * (b * 0.5 * size[1])
                + axes[2] * (c * 0.5 * size[2])
        };
        for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            self.edge(corner(x, y, -1.0), corner(x, y, 1.0), EdgeKind::Crease);
        }
        for z in [-1.0, 1.0] {
            for (a, b) in [
                ((-1.0, -1.0), (1.0, -1.0)),
                ((1.0, -1.0), (1.0, 1.0)),
                ((1.0, 1.0), (-1.0, 1.0)),
                ((-1.0, 1.0), (-1.0, -1.0)),
            ] {
                self.edge(corner(a.0, a.1, z), corner(b.0, b.1, z), EdgeKind::Crease);
            }
        }
    }

    /// Finishes the scene.
    pub fn finish(
        self,
        kind: SceneKind,
        bounds: Aabb,
        free_space: Aabb,
        lamp: Point3<f64>,
        base_yaws: Vec<f64>,
    ) -> Scene {
        Scene {
            kind,
            quads: self.quads,
            textures: self.textures,
            edges: self.edges,
            bounds,
            free_space,
            lamp,
            base_yaws,
        }
    }
}
