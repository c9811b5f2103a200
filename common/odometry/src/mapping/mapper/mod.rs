//! Local mapping (paper section III-C): a new keyframe is inserted, its unmatched close
//! keypoints and valid 3D lines become landmarks, duplicates are fused, the local BA
//! refines the covisible keyframes and their landmarks with reprojection, structural and
//! Manhattan terms, and redundant keyframes are culled (on points **and** lines).

use crate::config::{KeyframeConfig, MappingConfig, OdometryConfig};
use crate::frontend::features::hamming;
use crate::map::manhattan::WorldManhattan;
use crate::map::{KeyFrame, Map, MapLine, MapPoint};
use crate::mapping::local_ba::LocalMapBa;
use crate::mapping::plane_mapping::map_planes;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::plane_association::PlaneTrackingConfig;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{KeyFrameId, MapPointId};
use gfs_points::KeyPointGrid;
use nalgebra::Point3;

/// Keyframes after which a recently created point must have more than
/// `RECENT_POINT_MAX_WEAK_OBSERVATIONS` observations, one with depth counting twice
/// (ORB-SLAM2 `MapPointCulling` for RGB-D: a stereo observation counts two, and points
/// with at most 3 are dropped, so two keyframes with depth keep a point).
const RECENT_POINT_KEYFRAMES: u64 = 2;
const RECENT_POINT_MAX_WEAK_OBSERVATIONS: usize = 3;
/// Found/visible ratio under which a recent landmark is dropped (ORB-SLAM2: 0.25).
const MIN_FOUND_RATIO: f64 = 0.25;
/// Search radius when fusing, pixels at level 0 (ORB-SLAM2 `Fuse`: 3 x scale).
const FUSE_RADIUS_PX: f64 = 3.0;
/// Chi-square bounds (95 %) of a keypoint's agreement with a projection, 2 and 3 dof.
const CHI2_2DOF: f64 = 5.991;
const CHI2_3DOF: f64 = 7.815;
/// Cell of the keypoint grid the fusion searches in, pixels.
const FUSE_GRID_CELL_PX: f32 = 10.0;
/// Covisible keyframes whose points are fused into a new keyframe.
const FUSE_NEIGHBOURS: usize = 10;
/// A map line is judged on its found / visible ratio once this many frames predicted
/// it in view (a recent line has been predicted too few times for the ratio to mean
/// anything).
const LINE_CULL_MIN_VISIBLE: u32 = 8;

/// Owns the map-building steps; the map itself is passed in.
pub struct Mapper {
    config: MappingConfig,
    keyframes: KeyframeConfig,
    camera: PinholeCamera,
    scale: ScalePyramid,
    close_depth_m: f32,
    recent_points: Vec<MapPointId>,
    ba: LocalMapBa,
    grid: KeyPointGrid,
    nearby: Vec<usize>,
    planes: PlaneTrackingConfig,
    /// `[loop_closing] min_keyframe_gap`: how much older a keyframe of an earlier pass
    /// over a place is.
    earlier_pass_gap: u64,
}

impl Mapper {
    /// A mapper for `camera` whose keypoints come from the pyramid `scale`.
    pub fn new(config: &OdometryConfig, camera: PinholeCamera, scale: ScalePyramid) -> Self {
        Self {
            ba: LocalMapBa::new(
                config.mapping.clone(),
                camera,
                scale,
                config.tracking.planes.clone(),
            ),
            recent_points: Vec::new(),
            grid: KeyPointGrid::new(camera.width, camera.height, FUSE_GRID_CELL_PX),
            nearby: Vec::new(),
            planes: config.tracking.planes.clone(),
            config: config.mapping.clone(),
            keyframes: config.keyframes.clone(),
            camera,
            scale,
            close_depth_m: config.tracking.close_depth_m,
            earlier_pass_gap: config.loop_closing.min_keyframe_gap,
        }
    }

    /// The map points created recently and not yet confirmed or culled (the mapper's
    /// only state besides the map, for checkpoints).
    pub fn recent_points(&self) -> &[MapPointId] {
        &self.recent_points
    }

    /// Resumes with the recent points of a checkpoint.
    pub fn restore_recent_points(&mut self, points: Vec<MapPointId>) {
        self.recent_points = points;
    }

    /// Makes `frame` a keyframe of `map` and runs local mapping. Returns its id.
    pub fn add_keyframe(
        &mut self,
        map: &mut Map,
        frame: &TrackedFrame,
        manhattan: &mut WorldManhattan,
    ) -> KeyFrameId {
        self.add_keyframe_until(map, frame, manhattan, &|| false)
    }

    /// [`Self::add_keyframe`] with a local BA that stops early once `stop` answers true
    /// ([`LocalMapBa::run`]).
    pub fn add_keyframe_until(
        &mut self,
        map: &mut Map,
        frame: &TrackedFrame,
        manhattan: &mut WorldManhattan,
        stop: &dyn Fn() -> bool,
    ) -> KeyFrameId {
        let keyframe = KeyFrame {
            id: map.next_keyframe_id(),
            camera_from_world: frame.camera_from_world,
            features: frame.features.without_depth(),
            point_ids: frame.point_ids.clone(),
            line_ids: frame.line_ids.clone(),
            plane_ids: frame.plane_ids.clone(),
            loop_correction: nalgebra::Isometry3::identity(),
        };
        let kf = map.insert_keyframe(keyframe);
        for id in frame.point_ids.iter().flatten() {
            map.update_descriptor(*id);
            map.update_point_geometry(*id, self.scale.scale_factor, self.scale.levels);
        }
        self.create_points(map, kf);
        self.create_lines(map, kf, manhattan);
        // The frames carry planes only with `[tracking] use_planes`.
        map_planes(
            map,
            kf,
            &self.planes,
            manhattan,
            self.config.manhattan_angle_deg.to_radians(),
        );
        self.cull_recent_points(map, kf);
        self.fuse(map, kf);
        if self.config.local_ba {
            self.ba.run(map, kf, manhattan, stop);
        }
        self.cull_keyframes(map, kf);
        self.bound_map(map, kf);
        kf
    }

    /// New map points for unmatched keypoints with depth: all the close ones, and at
    /// least the `min_new_points` closest (ORB-SLAM2 RGB-D `CreateNewKeyFrame`); the
    /// first keyframe of a map gets one for every keypoint with depth (ORB-SLAM2
    /// `StereoInitialization`), or a map started in a far scene has too few points to
    /// track the next frames.
    fn create_points(&mut self, map: &mut Map, kf: KeyFrameId) {
        let first = map.keyframe_count() == 1;
        let Some(keyframe) = map.keyframe(kf) else {
            return;
        };
        let world_from_camera = keyframe.world_from_camera();
        let mut by_depth: Vec<(f32, usize)> = keyframe
            .features
            .keypoints
            .iter()
            .enumerate()
            .filter(|(i, kp)| kp.depth > 0.0 && keyframe.point_ids[*i].is_none())
            .map(|(i, kp)| (kp.depth, i))
            .collect();
        by_depth.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let centre = world_from_camera.translation.vector;
        let mut new_points = Vec::new();
        for (n, (depth, i)) in by_depth.into_iter().enumerate() {
            if !first && depth > self.close_depth_m && n >= self.config.min_new_points {
                break;
            }
            let kp = &keyframe.features.keypoints[i];
            let p_c = self
                .camera
                .back_project(f64::from(kp.u), f64::from(kp.v), f64::from(depth));
            let position = world_from_camera * p_c;
            let to_camera = centre - position.coords;
            let distance = to_camera.norm();
            let max_distance = distance * self.scale.factor(kp.level as u8);
            let point = MapPoint {
                position,
                descriptor: keyframe.features.point_descriptors[i],
                observations: Vec::new(),
                normal: to_camera / distance.max(1e-9),
                max_distance,
                min_distance: max_distance / self.scale.factor(self.scale.levels.saturating_sub(1)),
                first_kf: kf,
                visible: 1,
                found: 1,
            };
            new_points.push((i, point));
        }
        for (i, point) in new_points {
            if let Some(id) = map.insert_landmark(point, kf, i) {
                self.recent_points.push(id);
            }
        }
    }

    /// New map lines from the keyframe's unmatched valid 3D lines.
    fn create_lines(&mut self, map: &mut Map, kf: KeyFrameId, manhattan: &WorldManhattan) {
        let Some(keyframe) = map.keyframe(kf) else {
            return;
        };
        let world_from_camera = keyframe.world_from_camera();
        let mut new_lines = Vec::new();
        for (j, line3) in keyframe.features.lines3d.iter().enumerate() {
            if !line3.is_valid() || keyframe.line_ids[j].is_some() {
                continue;
            }
            let depth = [f64::from(line3.start[2]), f64::from(line3.end[2])];
            let start = world_from_camera * Point3::from(line3.start.map(f64::from));
            let end = world_from_camera * Point3::from(line3.end.map(f64::from));
            let descriptor = keyframe.features.line_descriptors[j];
            new_lines.push((j, start, end, depth, descriptor));
        }
        for (j, start, end, measured_depth, descriptor) in new_lines {
            let axis =
                manhattan.axis_of(&(end - start), self.config.manhattan_angle_deg.to_radians());
            let line = MapLine {
                start,
                end,
                measured: [start, end],
                measured_depth,
                descriptor,
                observations: Vec::new(),
                axis,
                first_kf: kf,
                visible: 1,
                found: 1,
            };
            map.insert_landmark(line, kf, j);
        }
    }

    /// Drops recent points that tracking rarely finds or that few keyframes confirm.
    fn cull_recent_points(&mut self, map: &mut Map, current: KeyFrameId) {
        let mut kept = Vec::with_capacity(self.recent_points.len());
        for id in std::mem::take(&mut self.recent_points) {
            let Some(p) = map.point(id) else { continue };
            let age = current.0.saturating_sub(p.first_kf.0);
            let observations: usize = p
                .observations
                .iter()
                .map(|(kf, i)| {
                    let has_depth = map
                        .keyframe(*kf)
                        .and_then(|k| k.features.keypoints.get(*i as usize))
                        .is_some_and(|kp| kp.depth > 0.0);
                    1 + usize::from(has_depth)
                })
                .sum();
            if p.found_ratio() < MIN_FOUND_RATIO
                || (age >= RECENT_POINT_KEYFRAMES
                    && observations <= RECENT_POINT_MAX_WEAK_OBSERVATIONS)
            {
                map.remove_landmark(id);
            } else if age < RECENT_POINT_KEYFRAMES + 1 {
                kept.push(id);
            }
        }
        self.recent_points = kept;
        let bad_lines: Vec<_> = map
            .line_ids()
            .filter(|id| {
                map.line(*id).is_some_and(|l| {
                    l.visible >= LINE_CULL_MIN_VISIBLE && l.found_ratio() < MIN_FOUND_RATIO
                })
            })
            .collect();
        for id in bad_lines {
            map.remove_landmark(id);
        }
    }

    /// Fuses duplicates around keyframe `kf` after a loop correction brought the two
    /// sides of the loop together: into `kf` and into each of its connected keyframes,
    /// the points of their covisible keyframes.
    pub fn fuse_around(&mut self, map: &mut Map, kf: KeyFrameId) {
        let around: Vec<KeyFrameId> = std::iter::once(kf)
            .chain(map.connected(kf).into_iter().map(|(k, _)| k))
            .take(FUSE_NEIGHBOURS + 1)
            .collect();
        for k in around {
            self.fuse(map, k);
        }
    }

    /// Projects the points of the covisible keyframes into the new one: a free keypoint
    /// that matches gets the observation; one that already has a map point is merged with
    /// it (the point with more observations survives).
    fn fuse(&mut self, map: &mut Map, kf: KeyFrameId) {
        let neighbours: Vec<KeyFrameId> = map
            .connected(kf)
            .into_iter()
            .take(FUSE_NEIGHBOURS)
            .map(|(k, _)| k)
            .collect();
        let mut candidates: Vec<MapPointId> = Vec::new();
        for n in &neighbours {
            if let Some(k) = map.keyframe(*n) {
                candidates.extend(k.point_ids.iter().flatten());
            }
        }
        candidates.sort_unstable();
        candidates.dedup();
        if let Some(keyframe) = map.keyframe(kf) {
            self.grid.build(&keyframe.features.keypoints);
        }
        for id in candidates {
            let Some(keyframe) = map.keyframe(kf) else {
                return;
            };
            if keyframe.point_ids.contains(&Some(id)) {
                continue;
            }
            let Some(point) = map.point(id) else { continue };
            let p_c = keyframe.camera_from_world * point.position;
            let Some(uv) = self.camera.project(&p_c) else {
                continue;
            };
            if !self.camera.contains(uv.x, uv.y, 0.0) {
                continue;
            }
            let level =
                point.predict_level(p_c.coords.norm(), self.scale.log_scale, self.scale.levels);
            let radius = FUSE_RADIUS_PX * self.scale.factor(level);
            self.grid.features_in_area(
                uv.x as f32,
                uv.y as f32,
                radius as f32,
                u32::from(level.saturating_sub(1)),
                u32::from(level) + 1,
                &mut self.nearby,
            );
            // ORB-SLAM2's `Fuse` gate: the keypoint must agree with the projection within
            // the chi-square bound of its level, including the depth as a virtual right
            // coordinate when it has one.
            let bf = self.config.ba.bf;
            let predicted_right = uv.x - bf / p_c.z;
            let consistent = |i: &usize| {
                let kp = &keyframe.features.keypoints[*i];
                let (ex, ey) = (uv.x - f64::from(kp.u), uv.y - f64::from(kp.v));
                let inv_sigma2 = self.scale.inv_sigma2(kp.level);
                if kp.depth > 0.0 {
                    let er = predicted_right - (f64::from(kp.u) - bf / f64::from(kp.depth));
                    (ex * ex + ey * ey + er * er) * inv_sigma2 <= CHI2_3DOF
                } else {
                    (ex * ex + ey * ey) * inv_sigma2 <= CHI2_2DOF
                }
            };
            let best = self
                .nearby
                .iter()
                .filter(|i| consistent(i))
                .map(|&i| {
                    (
                        hamming(&point.descriptor, &keyframe.features.point_descriptors[i]),
                        i,
                    )
                })
                .min();
            let Some((distance, i)) = best else { continue };
            if distance > self.config.fuse_max_distance {
                continue;
            }
            match keyframe.point_ids[i] {
                None => {
                    map.link(id, kf, i);
                }
                Some(existing) if existing != id => {
                    let n_existing = map.point(existing).map_or(0, |p| p.observations.len());
                    let n_candidate = map.point(id).map_or(0, |p| p.observations.len());
                    if n_existing >= n_candidate {
                        map.merge(id, existing);
                    } else {
                        map.merge(existing, id);
                    }
                }
                Some(_) => {}
            }
        }
    }

    /// Removes covisible keyframes whose points **and** lines are mostly seen by at least
    /// `redundant_observers` other keyframes (paper: redundancy on both feature kinds),
    /// or by `revisit_observers` when one of them is of an earlier pass over the place.
    fn cull_keyframes(&mut self, map: &mut Map, current: KeyFrameId) {
        let first = map.keyframe_ids().first().copied();
        let redundant = Redundancy {
            observers: self.keyframes.redundant_observers,
            revisit_observers: self.keyframes.revisit_observers,
            closed_through: map.closed_through(),
            gap: self.earlier_pass_gap,
        };
        for (kf, _) in map.connected(current) {
            if Some(kf) == first || kf == current {
                continue;
            }
            let Some(keyframe) = map.keyframe(kf) else {
                continue;
            };
            // Other keyframes besides `kf` itself.
            let observers = redundant.observers_for(kf, || map.connected(kf)) + 1;
            let (mut points, mut redundant_points) = (0usize, 0usize);
            for (i, id) in keyframe.point_ids.iter().enumerate() {
                let Some(p) = id.and_then(|id| map.point(id)) else {
                    continue;
                };
                if keyframe.features.keypoints[i].depth > self.close_depth_m {
                    continue;
                }
                points += 1;
                redundant_points += usize::from(p.observations.len() >= observers);
            }
            let (mut lines, mut redundant_lines) = (0usize, 0usize);
            for id in keyframe.line_ids.iter().flatten() {
                let Some(l) = map.line(*id) else { continue };
                lines += 1;
                redundant_lines += usize::from(l.observations.len() >= observers);
            }
            let points_redundant = points > 0
                && redundant_points as f32
                    >= self.keyframes.redundant_point_fraction * points as f32;
            let lines_redundant = lines == 0
                || redundant_lines as f32 >= self.keyframes.redundant_line_fraction * lines as f32;
            if points_redundant && lines_redundant {
                map.remove_keyframe(kf);
            }
        }
    }

    /// The safety cap of the global map (`max_keyframes`; its operating bound is the
    /// area explored, kept by `cull_keyframes`): beyond it, the oldest keyframes that
    /// are not covisible with the current one are dropped with the landmarks only they
    /// saw.
    fn bound_map(&mut self, map: &mut Map, current: KeyFrameId) {
        let excess = map
            .keyframe_count()
            .saturating_sub(self.keyframes.max_keyframes);
        if excess == 0 {
            return;
        }
        let local: Vec<KeyFrameId> = map
            .covisible(current, 1)
            .into_iter()
            .map(|(k, _)| k)
            .collect();
        let old: Vec<KeyFrameId> = map
            .keyframe_ids()
            .into_iter()
            .filter(|k| *k != current && !local.contains(k))
            .take(excess)
            .collect();
        for kf in old {
            map.remove_keyframe(kf);
        }
    }
}

/// How many other keyframes must see a keyframe's landmark for it to count towards the
/// keyframe's redundancy.
struct Redundancy {
    observers: usize,
    revisit_observers: usize,
    closed_through: Option<KeyFrameId>,
    gap: u64,
}

impl Redundancy {
    /// `revisit_observers` for a keyframe of a place an earlier pass mapped (connected
    /// to a keyframe made before the last loop closed and at least `gap` keyframes
    /// before it: `connected` gives its connected keyframes, asked for only once a loop
    /// has closed), else `observers`.
    fn observers_for(
        &self,
        kf: KeyFrameId,
        connected: impl FnOnce() -> Vec<(KeyFrameId, u32)>,
    ) -> usize {
        let Some(closed) = self.closed_through else {
            return self.observers;
        };
        let earlier_pass = |k: KeyFrameId| k <= closed && k.0.saturating_add(self.gap) <= kf.0;
        if connected().iter().any(|(k, _)| earlier_pass(*k)) {
            self.revisit_observers
        } else {
            self.observers
        }
    }
}

#[cfg(test)]
mod tests;
