//! A map plane: an infinite plane of the world (a wall, the floor) seen by one or more
//! keyframes as one of their BFS planes. Matched by geometry, not by descriptor.

use super::Map;
use gfs_core::ids::KeyFrameId;
use gfs_planes::Plane;
use nalgebra::{Isometry3, Vector3};

/// A landmark plane `normal . p + offset = 0` (world frame) with its observations.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MapPlane {
    /// Unit normal, world frame, on the side its observers saw it from.
    pub normal: Vector3<f64>,
    /// Offset, metres.
    pub offset: f64,
    /// Keyframes that see it, with the plane index in each.
    pub observations: Vec<(KeyFrameId, u32)>,
    /// The keyframe that created it.
    pub first_kf: KeyFrameId,
    /// Frames in whose view it was predicted to be.
    pub visible: u32,
    /// Frames in which it was matched.
    pub found: u32,
}

/// A frame plane moved into the world by `world_from_camera`: `(normal, offset)`.
pub fn plane_in_world(plane: &Plane, world_from_camera: &Isometry3<f64>) -> (Vector3<f64>, f64) {
    let n_c = Vector3::from(plane.normal.map(f64::from));
    let n_w = world_from_camera.rotation * n_c;
    // A point of the plane moves with the pose; the offset follows from it.
    let on_plane = -f64::from(plane.offset) * n_c;
    let p_w = world_from_camera * nalgebra::Point3::from(on_plane);
    (n_w, -n_w.dot(&p_w.coords))
}

impl MapPlane {
    /// A plane created from one keyframe's measurement.
    pub fn new(normal: Vector3<f64>, offset: f64) -> Self {
        Self {
            normal,
            offset,
            observations: Vec::new(),
            first_kf: KeyFrameId::default(),
            visible: 1,
            found: 1,
        }
    }
}

impl Map {
    /// Re-estimates a map plane as the pixel-weighted mean of its observations moved
    /// into the world by their keyframes' poses.
    pub fn update_plane_geometry(&mut self, id: gfs_core::ids::MapPlaneId) {
        let Some(plane) = self.planes.get(id) else {
            return;
        };
        let mut normal = Vector3::zeros();
        let mut offset = 0.0;
        let mut weight = 0.0;
        for (kf, index) in &plane.observations {
            let Some(keyframe) = self.keyframes.get(kf) else {
                continue;
            };
            let Some(seen) = keyframe.features.planes.get(*index as usize) else {
                continue;
            };
            let (n, d) = plane_in_world(seen, &keyframe.world_from_camera());
            let w = f64::from(seen.pixels);
            normal += w * n;
            offset += w * d;
            weight += w;
        }
        if weight <= 0.0 {
            return;
        }
        if let (Some(n), Some(p)) = (normal.try_normalize(1e-12), self.planes.items.get_mut(&id)) {
            p.normal = n;
            p.offset = offset / weight;
        }
    }
}
