//! The tracker's part of the global map: the keyframes around the camera, with every
//! landmark they observe. The mapping half keeps the whole map (bounded by the area
//! explored) and sends the tracker only this, so that the map update stays bounded
//! while the map grows. A neighbourhood's landmarks keep all their observations, some
//! of keyframes it does not hold (the tracker counts a landmark's observers, and reads
//! keyframes only through [`Map::keyframe`]).

use super::{KeyFrame, Landmark, Map, MapLine, MapPlane, MapPoint, Store};
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

/// Which keyframes make a neighbourhood.
#[derive(Clone, Copy, Debug)]
pub struct NeighbourhoodBounds {
    /// Most keyframes held.
    pub keyframes: usize,
    /// A keyframe shares the centre's view within this distance of its camera centre,
    /// metres ...
    pub view_radius_m: f64,
    /// ... and this angle between the optical axes, radians.
    pub view_angle_rad: f64,
}

impl NeighbourhoodBounds {
    /// The tracker's neighbourhood as `config` bounds it (`[mapping] tracker_keyframes`,
    /// `[tracking] view_radius_m` and `view_angle_deg`).
    pub fn of(config: &crate::config::OdometryConfig) -> Self {
        Self {
            keyframes: config.mapping.tracker_keyframes,
            view_radius_m: config.tracking.view_radius_m,
            view_angle_rad: config.tracking.view_angle_deg.to_radians(),
        }
    }
}

impl Map {
    /// The keyframe nearest to `world_from_camera`: the nearest of those sharing its
    /// view (`bounds`' radius and angle), else the nearest camera centre.
    pub fn nearest_keyframe(
        &self,
        world_from_camera: &Isometry3<f64>,
        bounds: &NeighbourhoodBounds,
    ) -> Option<KeyFrameId> {
        let mut sharing = Vec::new();
        self.keyframes_sharing_view(
            world_from_camera,
            bounds.view_radius_m,
            bounds.view_angle_rad,
            &mut sharing,
        );
        let distance = |kf: &KeyFrame| {
            (kf.world_from_camera().translation.vector - world_from_camera.translation.vector)
                .norm()
        };
        sharing.first().map(|(_, kf)| *kf).or_else(|| {
            self.keyframes
                .values()
                .min_by(|a, b| distance(a).total_cmp(&distance(b)).then(a.id.cmp(&b.id)))
                .map(|kf| kf.id)
        })
    }

    /// The keyframes whose view `world_from_camera` shares (camera centres within
    /// `radius_m`, optical axes within `angle_rad`), closest first, into `out`
    /// (cleared first; `(distance, keyframe)`).
    pub fn keyframes_sharing_view(
        &self,
        world_from_camera: &Isometry3<f64>,
        radius_m: f64,
        angle_rad: f64,
        out: &mut Vec<(f64, KeyFrameId)>,
    ) {
        out.clear();
        out.extend(self.keyframes.values().filter_map(|k| {
            k.view_distance(world_from_camera, radius_m, angle_rad)
                .map(|d| (d, k.id))
        }));
        out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }

    /// The keyframes of the neighbourhood of `centre`, at most `bounds.keyframes`, in
    /// this order of priority: `centre`; the keyframes sharing its view, closest first
    /// (a quarter of the room at most: the place the camera came back to); the keyframes
    /// covisible with it, strongest first; their connected neighbours. Empty when
    /// `centre` is not in the map.
    pub fn neighbourhood_of(
        &self,
        centre: KeyFrameId,
        bounds: &NeighbourhoodBounds,
    ) -> Vec<KeyFrameId> {
        let Some(keyframe) = self.keyframes.get(&centre) else {
            return Vec::new();
        };
        let limit = bounds.keyframes.max(1);
        let mut chosen = vec![centre];
        let add = |chosen: &mut Vec<KeyFrameId>, kf: KeyFrameId| {
            if chosen.len() < limit && self.keyframes.contains_key(&kf) && !chosen.contains(&kf) {
                chosen.push(kf);
            }
        };
        let mut view = Vec::new();
        self.keyframes_sharing_view(
            &keyframe.world_from_camera(),
            bounds.view_radius_m,
            bounds.view_angle_rad,
            &mut view,
        );
        let others = view.into_iter().filter(|(_, kf)| *kf != centre);
        for (_, kf) in others.take(limit.div_ceil(4)) {
            add(&mut chosen, kf);
        }
        let covisible: Vec<KeyFrameId> = self
            .covisible(centre, 1)
            .into_iter()
            .map(|(k, _)| k)
            .collect();
        for kf in &covisible {
            add(&mut chosen, *kf);
        }
        for kf in &covisible {
            if chosen.len() >= limit {
                break;
            }
            for (neighbour, _) in self.connected(*kf) {
                add(&mut chosen, neighbour);
            }
        }
        chosen
    }

    /// The sub-map of the keyframes `keep` (ids not in the map are skipped) with every
    /// landmark they observe, the retired keyframes (a frame's reference keyframe may be
    /// one), the id counters and the corrections; in canonical layout.
    pub fn neighbourhood(&self, keep: &[KeyFrameId]) -> Map {
        let mut out = Map {
            next_keyframe: self.next_keyframe,
            retired: self.retired.clone(),
            corrections: self.corrections,
            closed_through: self.closed_through,
            ..Map::default()
        };
        out.points.next = self.points.next;
        out.lines.next = self.lines.next;
        out.planes.next = self.planes.next;
        for kf in keep {
            let Some(keyframe) = self.keyframes.get(kf) else {
                continue;
            };
            copy_landmarks::<MapPoint>(&self.points, &mut out.points, keyframe);
            copy_landmarks::<MapLine>(&self.lines, &mut out.lines, keyframe);
            copy_landmarks::<MapPlane>(&self.planes, &mut out.planes, keyframe);
            out.keyframes.insert(*kf, keyframe.clone());
        }
        out.canonicalise();
        out
    }
}

/// Copies the landmarks of kind `L` that `keyframe` observes.
fn copy_landmarks<L: Landmark + Clone>(from: &Store<L>, to: &mut Store<L>, keyframe: &KeyFrame) {
    for id in L::slots(keyframe).iter().flatten() {
        if !to.items.contains_key(id)
            && let Some(landmark) = from.items.get(id)
        {
            to.items.insert(*id, landmark.clone());
        }
    }
}
