//! Plane landmarks in local mapping: a new keyframe's planes that tracking did not pair
//! join the map plane they agree with (normal and offset within the tracking gates, in
//! the world) or become new map planes; each plane the keyframe sees is re-estimated from
//! all its observations and, when its normal is within `max_axis_angle` of a world
//! Manhattan axis, turned onto that axis (the structural term of planes: walls and floor
//! of a Manhattan room are then exactly parallel or perpendicular); a plane no second
//! keyframe confirmed is culled.

use crate::map::manhattan::WorldManhattan;
use crate::map::{Map, MapPlane, plane_in_world};
use crate::tracking::plane_association::PlaneTrackingConfig;
use gfs_core::ids::{KeyFrameId, MapPlaneId};

/// Keyframes after which a plane seen by one keyframe only is dropped (as recent points
/// are after two: a plane fitted once may be a BFS region across two surfaces).
const PLANE_CONFIRM_KEYFRAMES: u64 = 3;

/// Links, creates, fuses and aligns the planes of keyframe `kf`, then culls unconfirmed
/// ones.
pub fn map_planes(
    map: &mut Map,
    kf: KeyFrameId,
    config: &PlaneTrackingConfig,
    manhattan: &WorldManhattan,
    max_axis_angle: f64,
) {
    let Some(keyframe) = map.keyframe(kf) else {
        return;
    };
    let world_from_camera = keyframe.world_from_camera();
    let min_cos = config.max_normal_angle_deg.to_radians().cos();
    let mut links: Vec<(usize, Option<MapPlaneId>, MapPlane)> = Vec::new();
    for (i, plane) in keyframe.features.planes.iter().enumerate() {
        if keyframe.plane_ids.get(i).is_none_or(Option::is_some) {
            continue;
        }
        let (normal, offset) = plane_in_world(plane, &world_from_camera);
        let best = map
            .planes()
            .ids()
            .filter(|id| !keyframe.plane_ids.contains(&Some(*id)))
            .filter_map(|id| {
                let p = map.plane(id)?;
                let cos = p.normal.dot(&normal);
                let gap = (p.offset - offset).abs();
                (cos >= min_cos && gap <= config.max_offset_m)
                    .then_some((gap / config.max_offset_m + (1.0 - cos), id))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(_, id)| id);
        links.push((i, best, MapPlane::new(normal, offset)));
    }
    for (i, existing, new) in links {
        let linked = match existing {
            Some(id) => map.link(id, kf, i),
            None => false,
        };
        if !linked {
            map.insert_landmark(new, kf, i);
        }
    }
    let seen: Vec<MapPlaneId> = map
        .keyframe(kf)
        .map(|k| k.plane_ids.iter().flatten().copied().collect())
        .unwrap_or_default();
    for id in seen {
        map.update_plane_geometry(id);
        align_with_axis(map, id, manhattan, max_axis_angle);
    }
    let unconfirmed: Vec<MapPlaneId> = map
        .planes()
        .ids()
        .filter(|id| {
            map.plane(*id).is_some_and(|p| {
                p.observations.len() < 2
                    && kf.0.saturating_sub(p.first_kf.0) >= PLANE_CONFIRM_KEYFRAMES
            })
        })
        .collect();
    for id in unconfirmed {
        map.remove_landmark(id);
    }
}

/// Turns a plane's normal onto the Manhattan axis it is within `max_angle` of, about
/// the plane's point nearest the world origin.
fn align_with_axis(map: &mut Map, id: MapPlaneId, manhattan: &WorldManhattan, max_angle: f64) {
    let Some(plane) = map.plane_mut(id) else {
        return;
    };
    let Some(axis) = manhattan
        .axis_of(&plane.normal, max_angle)
        .and_then(|k| manhattan.axis(k))
    else {
        return;
    };
    let on_plane = -plane.offset * plane.normal;
    let normal = axis * axis.dot(&plane.normal).signum();
    plane.normal = normal;
    plane.offset = -normal.dot(&on_plane);
}

#[cfg(test)]
mod tests {
    use crate::config::OdometryConfig;
    use crate::frontend::features::FrameFeatures;
    use crate::map::manhattan::WorldManhattan;
    use crate::mapping::mapper::Mapper;
    use crate::testing::{CORNER, camera, plane_map, planes_of, scale, tracked};
    use nalgebra::{Isometry3, Vector3};

    #[test]
    fn a_second_keyframe_of_the_same_planes_joins_them_and_a_new_wall_is_added() {
        let (mut map, _) = plane_map(&CORNER);
        // The fusion alone: the local BA would move the first keyframe onto the second's
        // planes (their planes determine both).
        let mut config = OdometryConfig::default();
        config.mapping.local_ba = false;
        let mut mapper = Mapper::new(&config, camera(), scale());
        // 10 cm along x, with the planes 5 mm off (their fused offsets move half way) and
        // a fourth wall behind the camera's start.
        let pose = Isometry3::translation(-0.1, 0.0, 0.0);
        let mut seen: Vec<([f64; 3], f64)> = CORNER.iter().map(|(n, d)| (*n, d + 0.005)).collect();
        seen.push(([1.0, 0.0, 0.0], -2.0));
        let features = FrameFeatures {
            planes: planes_of(&pose, &seen),
            ..FrameFeatures::default()
        };
        let kf = mapper.add_keyframe(
            &mut map,
            &tracked(features, pose),
            &mut WorldManhattan::new(false),
        );
        assert_eq!(map.planes().len(), 4);
        let keyframe = map.keyframe(kf).expect("kf");
        assert!(keyframe.plane_ids.iter().all(Option::is_some));
        for (i, (n, d)) in CORNER.iter().enumerate() {
            let id = keyframe.plane_ids[i].expect("linked");
            let plane = map.plane(id).expect("plane");
            assert_eq!(plane.observations.len(), 2);
            // n . x = d is (-n) . x + d = 0 with the normal towards the camera.
            let offset_along_n = -plane.offset * plane.normal.dot(&Vector3::from(*n)).signum();
            assert!(
                (offset_along_n - (d + 0.0025)).abs() < 1e-4,
                "{i}: {plane:?}"
            );
        }
    }
}
