//! The map: keyframes, map points and map lines in id-keyed arenas, with the
//! covisibility relation derived from shared observations. One owner (the mapper in the
//! pipeline, the [`crate::Odometry`] in-process); the tracker reads it.

mod arena;
mod canonical;
mod correction;
mod keyframe;
mod landmark;
mod line;
pub(crate) mod manhattan;
mod neighbourhood;
mod parts;
mod plane;
mod point;
mod retired;
mod scene;
mod validate;

/// The keyframes other than `kf` named in `observations` (one list per landmark `kf`
/// sees), with how many landmarks each shares, at least `min_shared`, strongest first
/// (newest first among equals).
fn rank_sharing<'a>(
    kf: KeyFrameId,
    observations: impl Iterator<Item = &'a Vec<(KeyFrameId, u32)>>,
    min_shared: u32,
) -> Vec<(KeyFrameId, u32)> {
    let mut counts: IdMap<KeyFrameId, u32> = IdMap::default();
    for observations in observations {
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

#[cfg(test)]
mod tests;

pub use arena::IdMap;
pub use keyframe::KeyFrame;
pub use landmark::{Described, Landmark, LandmarkId, Store};
pub use line::MapLine;
pub use neighbourhood::NeighbourhoodBounds;
pub(crate) use parts::{MapCounters, MapParts};
pub use plane::{MapPlane, plane_in_world};
pub use point::MapPoint;
pub use retired::RetiredKeyFrame;

use gfs_core::ids::{KeyFrameId, MapLineId, MapPlaneId, MapPointId};

/// Landmarks two keyframes must share to be connected in the covisibility graph
/// (ORB-SLAM2 `KeyFrame::UpdateConnections`: 15).
pub const COVISIBILITY_MIN_SHARED: u32 = 15;

/// Keyframes, landmarks and their links. Invariant: keyframe `k`'s slot `i` of a kind
/// holds landmark `l` exactly when `l`'s observations hold `(k, i)`; a landmark without
/// observations is removed. A tracker's neighbourhood ([`Map::neighbourhood`]) holds
/// the first half: its landmarks may be observed by keyframes it does not hold.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Map {
    keyframes: IdMap<KeyFrameId, KeyFrame>,
    points: Store<MapPoint>,
    lines: Store<MapLine>,
    #[serde(default)]
    planes: Store<MapPlane>,
    next_keyframe: u64,
    /// Keyframes removed from the map, each anchored to a keyframe kept at that time, so
    /// that a frame whose reference keyframe went still gets its final pose.
    retired: IdMap<KeyFrameId, RetiredKeyFrame>,
    /// Loop corrections applied so far.
    corrections: u64,
    /// See [`Map::closed_through`].
    #[serde(default)]
    closed_through: Option<KeyFrameId>,
}

impl Map {
    /// The next keyframe id that [`Self::insert_keyframe`] will assign.
    pub fn next_keyframe_id(&self) -> KeyFrameId {
        KeyFrameId(self.next_keyframe)
    }

    /// Adds a keyframe (its `id` field is overwritten) and returns its id. Links in
    /// its slots to landmarks that exist get observations; the others are cleared.
    pub fn insert_keyframe(&mut self, mut keyframe: KeyFrame) -> KeyFrameId {
        let id = KeyFrameId(self.next_keyframe);
        self.next_keyframe += 1;
        keyframe.id = id;
        self.observe_slots::<MapPoint>(&mut keyframe);
        self.observe_slots::<MapLine>(&mut keyframe);
        self.observe_slots::<MapPlane>(&mut keyframe);
        self.keyframes.insert(id, keyframe);
        id
    }

    fn observe_slots<L: Landmark>(&mut self, keyframe: &mut KeyFrame) {
        let (_, store) = L::store_mut(self);
        let kf = keyframe.id;
        for (i, slot) in L::slots_mut(keyframe).iter_mut().enumerate() {
            match slot.and_then(|l| store.items.get_mut(&l)) {
                Some(l) => l.observations_mut().push((kf, i as u32)),
                None => *slot = None,
            }
        }
    }

    /// Adds a landmark observed by feature `index` of keyframe `kf`; `None` when the
    /// keyframe or the feature does not exist or the feature already has a landmark.
    pub fn insert_landmark<L: Landmark>(
        &mut self,
        mut landmark: L,
        kf: KeyFrameId,
        index: usize,
    ) -> Option<L::Id> {
        let (keyframes, store) = L::store_mut(self);
        let slot = L::slots_mut(keyframes.get_mut(&kf)?).get_mut(index)?;
        if slot.is_some() {
            return None;
        }
        let id = L::id(store.next);
        store.next += 1;
        *slot = Some(id);
        *landmark.observations_mut() = vec![(kf, index as u32)];
        landmark.set_first_kf(kf);
        store.items.insert(id, landmark);
        Some(id)
    }

    /// Links feature `index` of keyframe `kf` to an existing landmark; false when one
    /// of them does not exist or the feature is linked already.
    pub fn link<I: LandmarkId>(&mut self, id: I, kf: KeyFrameId, index: usize) -> bool {
        let (keyframes, store) = I::Landmark::store_mut(self);
        let (Some(keyframe), Some(landmark)) = (keyframes.get_mut(&kf), store.items.get_mut(&id))
        else {
            return false;
        };
        match I::Landmark::slots_mut(keyframe).get_mut(index) {
            Some(slot @ None) => {
                *slot = Some(id);
                landmark.observations_mut().push((kf, index as u32));
                true
            }
            _ => false,
        }
    }

    /// Unlinks keyframe `kf` from a landmark (an outlier observation); the landmark
    /// goes when no observation is left.
    pub fn unlink<I: LandmarkId>(&mut self, id: I, kf: KeyFrameId) {
        let (keyframes, store) = I::Landmark::store_mut(self);
        let Some(landmark) = store.items.get_mut(&id) else {
            return;
        };
        let observations = landmark.observations_mut();
        let Some(pos) = observations.iter().position(|(k, _)| *k == kf) else {
            return;
        };
        let (_, index) = observations.swap_remove(pos);
        let empty = observations.is_empty();
        if let Some(slot) = keyframes
            .get_mut(&kf)
            .and_then(|k| I::Landmark::slots_mut(k).get_mut(index as usize))
        {
            *slot = None;
        }
        if empty {
            store.items.remove(&id);
        }
    }

    /// Removes a landmark and every link to it.
    pub fn remove_landmark<I: LandmarkId>(&mut self, id: I) {
        let (keyframes, store) = I::Landmark::store_mut(self);
        let Some(landmark) = store.items.remove(&id) else {
            return;
        };
        for (kf, index) in landmark.observations() {
            if let Some(slot) = keyframes
                .get_mut(kf)
                .and_then(|k| I::Landmark::slots_mut(k).get_mut(*index as usize))
            {
                *slot = None;
            }
        }
    }

    /// Removes every keyframe, and with them every landmark (a new local map starts).
    pub fn clear_keyframes(&mut self) {
        for kf in self.keyframe_ids() {
            self.remove_keyframe(kf);
        }
    }

    /// Removes a keyframe; landmarks it alone observed go with it. It is retired
    /// relative to its strongest covisible keyframe (or the newest older one).
    pub fn remove_keyframe(&mut self, id: KeyFrameId) {
        if !self.keyframes.contains_key(&id) {
            return;
        }
        self.retire(id);
        let Some(kf) = self.keyframes.remove(&id) else {
            return;
        };
        forget_keyframe::<MapPoint>(&mut self.points, &kf);
        forget_keyframe::<MapLine>(&mut self.lines, &kf);
        forget_keyframe::<MapPlane>(&mut self.planes, &kf);
    }

    /// Merges landmark `from` into `into`: observations move, `from` disappears, its
    /// sighting counts add up. When both are seen by the same keyframe, the link of
    /// `into` is kept.
    pub fn merge<I: LandmarkId>(&mut self, from: I, into: I) {
        let (keyframes, store) = I::Landmark::store_mut(self);
        if from == into || !store.items.contains_key(&into) {
            return;
        }
        let Some(mut old) = store.items.remove(&from) else {
            return;
        };
        for &(kf, index) in old.observations() {
            let Some(keyframe) = keyframes.get_mut(&kf) else {
                continue;
            };
            let slots = I::Landmark::slots_mut(keyframe);
            let already = slots.contains(&Some(into));
            let slot = &mut slots[index as usize];
            if already {
                *slot = None;
            } else {
                *slot = Some(into);
                if let Some(l) = store.items.get_mut(&into) {
                    l.observations_mut().push((kf, index));
                }
            }
        }
        let (visible, found) = old.sightings_mut();
        let (visible, found) = (*visible, *found);
        if let Some(l) = store.items.get_mut(&into) {
            let (v, f) = l.sightings_mut();
            *v += visible;
            *f += found;
        }
    }

    /// Picks as the landmark's descriptor the observation with the least median
    /// Hamming distance to the others (ORB-SLAM's distinctive descriptor).
    pub fn update_descriptor<I: LandmarkId>(&mut self, id: I)
    where
        I::Landmark: Described,
    {
        let Some(landmark) = I::Landmark::store(self).items.get(&id) else {
            return;
        };
        let descriptors: Vec<_> = landmark
            .observations()
            .iter()
            .filter_map(|(kf, i)| {
                I::Landmark::feature_descriptor(self.keyframes.get(kf)?, *i as usize)
            })
            .collect();
        if let Some(best) = landmark::most_central(&descriptors)
            && let Some(l) = I::Landmark::store_mut(self).1.items.get_mut(&id)
        {
            *l.descriptor_mut() = best;
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

    /// The map points.
    pub fn points(&self) -> &Store<MapPoint> {
        &self.points
    }

    /// The map lines.
    pub fn lines(&self) -> &Store<MapLine> {
        &self.lines
    }

    /// The map planes.
    pub fn planes(&self) -> &Store<MapPlane> {
        &self.planes
    }

    /// A map plane by id.
    pub fn plane(&self, id: MapPlaneId) -> Option<&MapPlane> {
        self.planes.get(id)
    }

    /// A map plane by id, mutable (its links stay as they are).
    pub fn plane_mut(&mut self, id: MapPlaneId) -> Option<&mut MapPlane> {
        self.planes.items.get_mut(&id)
    }

    /// A landmark of any kind by id, mutable (its links stay as they are).
    pub fn landmark_mut<I: LandmarkId>(&mut self, id: I) -> Option<&mut I::Landmark> {
        I::Landmark::store_mut(self).1.items.get_mut(&id)
    }

    /// A map point by id.
    pub fn point(&self, id: MapPointId) -> Option<&MapPoint> {
        self.points.get(id)
    }

    /// A map point by id, mutable (its links stay as they are).
    pub fn point_mut(&mut self, id: MapPointId) -> Option<&mut MapPoint> {
        self.points.items.get_mut(&id)
    }

    /// A map line by id.
    pub fn line(&self, id: MapLineId) -> Option<&MapLine> {
        self.lines.get(id)
    }

    /// A map line by id, mutable (its links stay as they are).
    pub fn line_mut(&mut self, id: MapLineId) -> Option<&mut MapLine> {
        self.lines.items.get_mut(&id)
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
        self.points.ids()
    }

    /// All map line ids (arbitrary order).
    pub fn line_ids(&self) -> impl Iterator<Item = MapLineId> + '_ {
        self.lines.ids()
    }

    /// Keyframes sharing landmarks with `kf`, with the number shared (points + lines),
    /// strongest first. Only those sharing at least `min_shared`.
    pub fn covisible(&self, kf: KeyFrameId, min_shared: u32) -> Vec<(KeyFrameId, u32)> {
        let Some(keyframe) = self.keyframes.get(&kf) else {
            return Vec::new();
        };
        let point_obs = keyframe
            .point_ids
            .iter()
            .flatten()
            .filter_map(|p| self.points.get(*p))
            .map(|p| &p.observations);
        let line_obs = keyframe
            .line_ids
            .iter()
            .flatten()
            .filter_map(|l| self.lines.get(*l))
            .map(|l| &l.observations);
        rank_sharing(kf, point_obs.chain(line_obs), min_shared)
    }

    /// Keyframes sharing map planes with `kf`, with the number shared, strongest first:
    /// the neighbourhood of a keyframe that shares no point or line, whose planes are
    /// all that tie it to the map.
    pub fn plane_covisible(&self, kf: KeyFrameId) -> Vec<(KeyFrameId, u32)> {
        let Some(keyframe) = self.keyframes.get(&kf) else {
            return Vec::new();
        };
        let plane_obs = keyframe
            .plane_ids
            .iter()
            .flatten()
            .filter_map(|p| self.planes.get(*p))
            .map(|p| &p.observations);
        rank_sharing(kf, plane_obs, 1)
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

    /// `kf` and its [`Self::connected`] keyframes: the place it sees.
    pub fn place_keyframes(&self, kf: KeyFrameId) -> Vec<KeyFrameId> {
        std::iter::once(kf)
            .chain(self.connected(kf).into_iter().map(|(k, _)| k))
            .collect()
    }

    /// The map points of the [`Self::place_keyframes`] of `kf`, the place it sees,
    /// sorted by id.
    pub fn place_points(&self, kf: KeyFrameId) -> Vec<MapPointId> {
        self.points_seen_by(&self.place_keyframes(kf))
    }

    /// The map points `keyframes` observe, sorted by id.
    pub fn points_seen_by(&self, keyframes: &[KeyFrameId]) -> Vec<MapPointId> {
        let mut ids: Vec<MapPointId> = keyframes
            .iter()
            .filter_map(|k| self.keyframes.get(k))
            .flat_map(|k| k.point_ids.iter().flatten().copied())
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// Recomputes the viewing direction and the scale-invariance distances of a point.
    pub fn update_point_geometry(&mut self, id: MapPointId, scale_factor: f64, levels: u8) {
        let Some(p) = self.points.get(id) else {
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
        if let Some(p) = self.points.items.get_mut(&id) {
            p.normal = normal.try_normalize(1e-12).unwrap_or(p.normal);
            p.max_distance = max_distance;
            p.min_distance = min_distance;
        }
    }
}

/// Drops the observations of a removed keyframe from its landmarks of kind `L`; a
/// landmark left without any goes, and one it created is re-anchored to its oldest
/// remaining observer.
fn forget_keyframe<L: Landmark>(store: &mut Store<L>, keyframe: &KeyFrame) {
    for id in L::slots(keyframe).iter().flatten() {
        if let Some(l) = store.items.get_mut(id) {
            l.observations_mut().retain(|(k, _)| *k != keyframe.id);
            if l.observations().is_empty() {
                store.items.remove(id);
            } else if l.first_kf() == keyframe.id {
                let first = l.observations()[0].0;
                l.set_first_kf(first);
            }
        }
    }
}
