//! The map: keyframes, map points and map lines in id-keyed arenas, with the
//! covisibility relation derived from shared observations. One owner (the mapper in the
//! pipeline, the [`crate::Odometry`] in-process); the tracker reads it.

mod arena;
mod canonical;
mod keyframe;
mod line;
mod point;

pub use arena::IdMap;
pub use keyframe::KeyFrame;
pub use line::MapLine;
pub use point::MapPoint;

use crate::frame::{Descriptor, hamming};
use gfs_core::ids::{KeyFrameId, MapLineId, MapPointId};

/// Landmarks two keyframes must share to be connected in the covisibility graph
/// (ORB-SLAM2 `KeyFrame::UpdateConnections`: 15).
pub const COVISIBILITY_MIN_SHARED: u32 = 15;
use nalgebra::Rotation3;

/// Keyframes, landmarks and their links.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Map {
    keyframes: IdMap<KeyFrameId, KeyFrame>,
    points: IdMap<MapPointId, MapPoint>,
    lines: IdMap<MapLineId, MapLine>,
    next_keyframe: u64,
    next_point: u64,
    next_line: u64,
    /// Manhattan axes of the world (columns), once the scene has shown them.
    pub manhattan: Option<Rotation3<f64>>,
}

impl Map {
    /// The next keyframe id that [`Self::insert_keyframe`] will assign.
    pub fn next_keyframe_id(&self) -> KeyFrameId {
        KeyFrameId(self.next_keyframe)
    }

    /// Adds a keyframe (its `id` field is overwritten) and returns its id. Links in
    /// `point_ids` / `line_ids` must already exist; observations are added for them.
    pub fn insert_keyframe(&mut self, mut keyframe: KeyFrame) -> KeyFrameId {
        let id = KeyFrameId(self.next_keyframe);
        self.next_keyframe += 1;
        keyframe.id = id;
        for (i, pid) in keyframe.point_ids.iter_mut().enumerate() {
            match pid.and_then(|p| self.points.get_mut(&p)) {
                Some(p) => p.observations.push((id, i as u32)),
                None => *pid = None,
            }
        }
        for (i, lid) in keyframe.line_ids.iter_mut().enumerate() {
            match lid.and_then(|l| self.lines.get_mut(&l)) {
                Some(l) => l.observations.push((id, i as u32)),
                None => *lid = None,
            }
        }
        self.keyframes.insert(id, keyframe);
        id
    }

    /// Adds a map point observed by keypoint `index` of keyframe `kf`.
    pub fn insert_point(
        &mut self,
        mut point: MapPoint,
        kf: KeyFrameId,
        index: usize,
    ) -> Option<MapPointId> {
        let keyframe = self.keyframes.get_mut(&kf)?;
        let slot = keyframe.point_ids.get_mut(index)?;
        if slot.is_some() {
            return None;
        }
        let id = MapPointId(self.next_point);
        self.next_point += 1;
        *slot = Some(id);
        point.observations = vec![(kf, index as u32)];
        point.first_kf = kf;
        self.points.insert(id, point);
        Some(id)
    }

    /// Adds a map line observed by line `index` of keyframe `kf`.
    pub fn insert_line(
        &mut self,
        mut line: MapLine,
        kf: KeyFrameId,
        index: usize,
    ) -> Option<MapLineId> {
        let keyframe = self.keyframes.get_mut(&kf)?;
        let slot = keyframe.line_ids.get_mut(index)?;
        if slot.is_some() {
            return None;
        }
        let id = MapLineId(self.next_line);
        self.next_line += 1;
        *slot = Some(id);
        line.observations = vec![(kf, index as u32)];
        line.first_kf = kf;
        self.lines.insert(id, line);
        Some(id)
    }

    /// Links keypoint `index` of keyframe `kf` to an existing map point.
    pub fn add_point_observation(
        &mut self,
        point: MapPointId,
        kf: KeyFrameId,
        index: usize,
    ) -> bool {
        let (Some(keyframe), Some(p)) = (self.keyframes.get_mut(&kf), self.points.get_mut(&point))
        else {
            return false;
        };
        match keyframe.point_ids.get_mut(index) {
            Some(slot @ None) => {
                *slot = Some(point);
                p.observations.push((kf, index as u32));
                true
            }
            _ => false,
        }
    }

    /// Links line `index` of keyframe `kf` to an existing map line.
    pub fn add_line_observation(&mut self, line: MapLineId, kf: KeyFrameId, index: usize) -> bool {
        let (Some(keyframe), Some(l)) = (self.keyframes.get_mut(&kf), self.lines.get_mut(&line))
        else {
            return false;
        };
        match keyframe.line_ids.get_mut(index) {
            Some(slot @ None) => {
                *slot = Some(line);
                l.observations.push((kf, index as u32));
                true
            }
            _ => false,
        }
    }

    /// Unlinks keyframe `kf` from map point `point` (an outlier observation); the point
    /// goes when no observation is left.
    pub fn remove_point_observation(&mut self, point: MapPointId, kf: KeyFrameId) {
        let Some(p) = self.points.get_mut(&point) else {
            return;
        };
        let Some(pos) = p.observations.iter().position(|(k, _)| *k == kf) else {
            return;
        };
        let (_, index) = p.observations.swap_remove(pos);
        let empty = p.observations.is_empty();
        if let Some(slot) = self
            .keyframes
            .get_mut(&kf)
            .and_then(|k| k.point_ids.get_mut(index as usize))
        {
            *slot = None;
        }
        if empty {
            self.points.remove(&point);
        }
    }

    /// Unlinks keyframe `kf` from map line `line`; the line goes when no observation is
    /// left.
    pub fn remove_line_observation(&mut self, line: MapLineId, kf: KeyFrameId) {
        let Some(l) = self.lines.get_mut(&line) else {
            return;
        };
        let Some(pos) = l.observations.iter().position(|(k, _)| *k == kf) else {
            return;
        };
        let (_, index) = l.observations.swap_remove(pos);
        let empty = l.observations.is_empty();
        if let Some(slot) = self
            .keyframes
            .get_mut(&kf)
            .and_then(|k| k.line_ids.get_mut(index as usize))
        {
            *slot = None;
        }
        if empty {
            self.lines.remove(&line);
        }
    }

    /// Removes a map point and every link to it.
    pub fn remove_point(&mut self, id: MapPointId) {
        if let Some(p) = self.points.remove(&id) {
            for (kf, index) in p.observations {
                if let Some(slot) = self
                    .keyframes
                    .get_mut(&kf)
                    .and_then(|k| k.point_ids.get_mut(index as usize))
                {
                    *slot = None;
                }
            }
        }
    }

    /// Removes a map line and every link to it.
    pub fn remove_line(&mut self, id: MapLineId) {
        if let Some(l) = self.lines.remove(&id) {
            for (kf, index) in l.observations {
                if let Some(slot) = self
                    .keyframes
                    .get_mut(&kf)
                    .and_then(|k| k.line_ids.get_mut(index as usize))
                {
                    *slot = None;
                }
            }
        }
    }

    /// Removes every keyframe, and with them every landmark (a new local map starts).
    pub fn clear_keyframes(&mut self) {
        for kf in self.keyframe_ids() {
            self.remove_keyframe(kf);
        }
    }

    /// Removes a keyframe; landmarks it alone observed go with it.
    pub fn remove_keyframe(&mut self, id: KeyFrameId) {
        let Some(kf) = self.keyframes.remove(&id) else {
            return;
        };
        for pid in kf.point_ids.iter().flatten() {
            if let Some(p) = self.points.get_mut(pid) {
                p.observations.retain(|(k, _)| *k != id);
                if p.observations.is_empty() {
                    self.points.remove(pid);
                } else if p.first_kf == id {
                    p.first_kf = p.observations[0].0;
                }
            }
        }
        for lid in kf.line_ids.iter().flatten() {
            if let Some(l) = self.lines.get_mut(lid) {
                l.observations.retain(|(k, _)| *k != id);
                if l.observations.is_empty() {
                    self.lines.remove(lid);
                } else if l.first_kf == id {
                    l.first_kf = l.observations[0].0;
                }
            }
        }
    }

    /// Merges map point `from` into `into`: observations move, `from` disappears. When
    /// both are seen by the same keyframe, the link of `into` is kept.
    pub fn merge_points(&mut self, from: MapPointId, into: MapPointId) {
        if from == into || !self.points.contains_key(&into) {
            return;
        }
        let Some(old) = self.points.remove(&from) else {
            return;
        };
        for (kf, index) in old.observations {
            let Some(keyframe) = self.keyframes.get_mut(&kf) else {
                continue;
            };
            let already = keyframe.point_ids.contains(&Some(into));
            let slot = &mut keyframe.point_ids[index as usize];
            if already {
                *slot = None;
            } else {
                *slot = Some(into);
                if let Some(p) = self.points.get_mut(&into) {
                    p.observations.push((kf, index));
                }
            }
        }
        if let Some(p) = self.points.get_mut(&into) {
            p.visible += old.visible;
            p.found += old.found;
        }
    }

    /// A keyframe by id.
    pub fn keyframe(&self, id: KeyFrameId) -> Option<&KeyFrame> {
        self.keyframes.get(&id)
    }

    /// A keyframe by id, mutable.
    pub fn keyframe_mut(&mut self, id: KeyFrameId) -> Option<&mut KeyFrame> {
        self.keyframes.get_mut(&id)
    }

    /// A map point by id.
    pub fn point(&self, id: MapPointId) -> Option<&MapPoint> {
        self.points.get(&id)
    }

    /// A map point by id, mutable.
    pub fn point_mut(&mut self, id: MapPointId) -> Option<&mut MapPoint> {
        self.points.get_mut(&id)
    }

    /// A map line by id.
    pub fn line(&self, id: MapLineId) -> Option<&MapLine> {
        self.lines.get(&id)
    }

    /// A map line by id, mutable.
    pub fn line_mut(&mut self, id: MapLineId) -> Option<&mut MapLine> {
        self.lines.get_mut(&id)
    }

    /// All keyframes (arbitrary order).
    pub fn keyframes(&self) -> impl Iterator<Item = &KeyFrame> {
        self.keyframes.values()
    }

    /// Keyframe ids in increasing order (= insertion order).
    pub fn keyframe_ids(&self) -> Vec<KeyFrameId> {
        let mut ids: Vec<_> = self.keyframes.keys().copied().collect();
        ids.sort_unstable();
        ids
    }

    /// Number of keyframes.
    pub fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// Number of map points.
    pub fn point_count(&self) -> usize {
        self.points.len()
    }

    /// Number of map lines.
    pub fn line_count(&self) -> usize {
        self.lines.len()
    }

    /// All map point ids (arbitrary order).
    pub fn point_ids(&self) -> impl Iterator<Item = MapPointId> + '_ {
        self.points.keys().copied()
    }

    /// All map line ids (arbitrary order).
    pub fn line_ids(&self) -> impl Iterator<Item = MapLineId> + '_ {
        self.lines.keys().copied()
    }

    /// Keyframes sharing landmarks with `kf`, with the number shared (points + lines),
    /// strongest first. Only those sharing at least `min_shared`.
    pub fn covisible(&self, kf: KeyFrameId, min_shared: u32) -> Vec<(KeyFrameId, u32)> {
        let Some(keyframe) = self.keyframes.get(&kf) else {
            return Vec::new();
        };
        let mut counts: IdMap<KeyFrameId, u32> = IdMap::default();
        let point_obs = keyframe
            .point_ids
            .iter()
            .flatten()
            .filter_map(|p| self.points.get(p))
            .map(|p| &p.observations);
        let line_obs = keyframe
            .line_ids
            .iter()
            .flatten()
            .filter_map(|l| self.lines.get(l))
            .map(|l| &l.observations);
        for observations in point_obs.chain(line_obs) {
            for (other, _) in observations {
                if *other != kf {
                    *counts.entry(*other).or_insert(0) += 1;
                }
            }
        }
        let mut out: Vec<_> = counts
            .into_iter()
            .filter(|(_, n)| *n >= min_shared)
            .collect();
        out.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(b.0.cmp(&a.0)));
        out
    }

    /// The keyframes connected to `kf` in the covisibility graph: those sharing at least
    /// [`COVISIBILITY_MIN_SHARED`] landmarks, strongest first, or the strongest one alone
    /// when none does (ORB-SLAM2 `KeyFrame::UpdateConnections`).
    pub fn connected(&self, kf: KeyFrameId) -> Vec<(KeyFrameId, u32)> {
        let mut all = self.covisible(kf, 1);
        let strong = all
            .iter()
            .take_while(|(_, n)| *n >= COVISIBILITY_MIN_SHARED)
            .count();
        all.truncate(strong.max(1));
        all
    }

    /// Picks as the point's descriptor the observation with the least median Hamming
    /// distance to the others (ORB-SLAM's distinctive descriptor).
    pub fn update_point_descriptor(&mut self, id: MapPointId) {
        let Some(p) = self.points.get(&id) else {
            return;
        };
        let descriptors: Vec<Descriptor> = p
            .observations
            .iter()
            .filter_map(|(kf, i)| {
                self.keyframes
                    .get(kf)?
                    .features
                    .point_descriptors
                    .get(*i as usize)
                    .copied()
            })
            .collect();
        if let Some(best) = most_central(&descriptors)
            && let Some(p) = self.points.get_mut(&id)
        {
            p.descriptor = best;
        }
    }

    /// Like [`Self::update_point_descriptor`], for a map line's LBD descriptor.
    pub fn update_line_descriptor(&mut self, id: MapLineId) {
        let Some(l) = self.lines.get(&id) else { return };
        let descriptors: Vec<Descriptor> = l
            .observations
            .iter()
            .filter_map(|(kf, i)| {
                self.keyframes
                    .get(kf)?
                    .features
                    .line_descriptors
                    .get(*i as usize)
                    .copied()
            })
            .collect();
        if let Some(best) = most_central(&descriptors)
            && let Some(l) = self.lines.get_mut(&id)
        {
            l.descriptor = best;
        }
    }

    /// Recomputes the viewing direction and the scale-invariance distances of a point.
    pub fn update_point_geometry(&mut self, id: MapPointId, scale_factor: f64, levels: u8) {
        let Some(p) = self.points.get(&id) else {
            return;
        };
        let mut normal = nalgebra::Vector3::zeros();
        let mut reference: Option<(f64, u8)> = None;
        for (kf, index) in &p.observations {
            let Some(keyframe) = self.keyframes.get(kf) else {
                continue;
            };
            let centre = keyframe.camera_from_world.inverse().translation.vector;
            let to_camera = centre - p.position.coords;
            normal += to_camera.normalize();
            if (*kf == p.first_kf || reference.is_none())
                && let Some(kp) = keyframe.features.keypoints.get(*index as usize)
            {
                reference = Some((to_camera.norm(), kp.level.min(u32::from(u8::MAX)) as u8));
            }
        }
        let Some((distance, level)) = reference else {
            return;
        };
        let level_scale = scale_factor.powi(i32::from(level));
        let max_distance = distance * level_scale;
        let min_distance = max_distance / scale_factor.powi(i32::from(levels.saturating_sub(1)));
        if let Some(p) = self.points.get_mut(&id) {
            p.normal = normal.try_normalize(1e-12).unwrap_or(p.normal);
            p.max_distance = max_distance;
            p.min_distance = min_distance;
        }
    }
}

/// The descriptor with the least median distance to the others.
fn most_central(descriptors: &[Descriptor]) -> Option<Descriptor> {
    let n = descriptors.len();
    if n <= 2 {
        return descriptors.first().copied();
    }
    let mut row = vec![0u32; n];
    let mut best = (u32::MAX, 0);
    for (i, a) in descriptors.iter().enumerate() {
        for (j, b) in descriptors.iter().enumerate() {
            row[j] = hamming(a, b);
        }
        row.sort_unstable();
        let median = row[(n - 1) / 2];
        if median < best.0 {
            best = (median, i);
        }
    }
    Some(descriptors[best.1])
}
