//! Moving landmarks after their keyframes moved (a loop correction): each landmark
//! keeps its place relative to its reference keyframe (the one that created it, or its
//! oldest observer once that one went).

use super::Map;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

impl Map {
    /// Applies `new_from_old(first_kf)` to every point, line and plane whose reference keyframe
    /// it answers for; landmarks it answers `None` for stay.
    pub fn move_landmarks(&mut self, new_from_old: impl Fn(KeyFrameId) -> Option<Isometry3<f64>>) {
        for point in self.points.items.values_mut() {
            if let Some(t) = new_from_old(point.first_kf) {
                point.position = t * point.position;
                point.normal = t.rotation * point.normal;
            }
        }
        for line in self.lines.items.values_mut() {
            if let Some(t) = new_from_old(line.first_kf) {
                line.start = t * line.start;
                line.end = t * line.end;
                line.measured = line.measured.map(|p| t * p);
            }
        }
        for plane in self.planes.items.values_mut() {
            if let Some(t) = new_from_old(plane.first_kf) {
                // The plane's closest point to the origin moves as a point does.
                let on_plane = t * nalgebra::Point3::from(-plane.offset * plane.normal);
                plane.normal = t.rotation * plane.normal;
                plane.offset = -plane.normal.dot(&on_plane.coords);
            }
        }
    }
}
