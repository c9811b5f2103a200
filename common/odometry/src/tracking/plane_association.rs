//! Association of a frame's BFS planes with the map's planes (planes as landmarks):
//! each map plane is moved into the frame with the current pose estimate and
//! paired with the frame plane whose normal and offset agree within the gates; the pairs
//! become plane-to-plane observations of the pose optimisation.
//!
//! The offset's noise is a fraction of the sensor's depth noise at the plane's centroid
//! ([`crate::DepthNoise`]): a plane fitted over thousands of pixels averages the
//! random part away, but not the depth bias that grows with the range, which is what
//! the offset carries.

use crate::depth::noise::DepthNoise;
use crate::map::{Map, MapPlane};
use gfs_core::ids::MapPlaneId;
use gfs_optim::PlaneObservation;
use gfs_optim::residuals::PlaneToPlane;
use gfs_planes::Plane;
use nalgebra::{Isometry3, Matrix6, Vector3};
use serde::Deserialize;

/// Parameters of the plane landmarks (the odometry's TOML table `[tracking.planes]`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlaneTrackingConfig {
    /// Largest angle between a frame plane's normal and a predicted map plane's,
    /// degrees; default 10 (a frame's motion prediction is within a few degrees).
    pub max_normal_angle_deg: f64,
    /// Largest difference of their offsets, metres; default 0.05.
    pub max_offset_m: f64,
    /// Standard deviation of a plane normal, degrees; default 1.0 (the BFS mean normal
    /// of a region of noisy pixel normals; 0.25 measured worse on the synthetic
    /// low-texture rooms and TUM fr1: the map planes' own errors are not that small).
    pub normal_sigma_deg: f64,
    /// Factor on the sensor's depth noise at the plane's centroid that gives the
    /// offset's standard deviation; default 1.0 (the fit over the region averages the
    /// per-pixel noise, but the range-dependent bias and the normal's error stay).
    pub offset_sigma_scale: f64,
    /// The sensor's depth noise: a camera property, filled from `[depth] sensor`, not
    /// read from this table.
    #[serde(skip)]
    pub depth_noise: DepthNoise,
}

impl Default for PlaneTrackingConfig {
    fn default() -> Self {
        Self {
            max_normal_angle_deg: 10.0,
            max_offset_m: 0.05,
            normal_sigma_deg: 1.0,
            offset_sigma_scale: 1.0,
            depth_noise: DepthNoise::default(),
        }
    }
}

/// A frame plane as a measurement of the plane-to-plane error.
pub fn measured(plane: &Plane) -> PlaneToPlane {
    PlaneToPlane {
        normal_in_camera: Vector3::from(plane.normal.map(f64::from)),
        offset: f64::from(plane.offset),
    }
}

/// The weights of a frame plane's error (normal, offset), 1/rad^2 and 1/m^2.
fn information(config: &PlaneTrackingConfig, plane: &Plane) -> (f64, f64) {
    let offset_sigma =
        config.offset_sigma_scale * config.depth_noise.sigma(f64::from(plane.centroid[2]));
    (
        config.normal_sigma_deg.to_radians().powi(-2),
        offset_sigma.powi(-2),
    )
}

/// The information a frame's planes would give its own pose, were each paired with
/// itself: whether they can determine a pose at all (two parallel walls cannot).
pub fn self_information(config: &PlaneTrackingConfig, planes: &[Plane]) -> Matrix6<f64> {
    let mut h = Matrix6::zeros();
    for plane in planes {
        let m = measured(plane);
        let l = m.linearize(&Isometry3::identity(), &m.normal_in_camera, m.offset);
        let (wn, wd) = information(config, plane);
        let w = nalgebra::Matrix4::from_diagonal(&nalgebra::Vector4::new(wn, wn, wn, wd));
        h += l.d_pose.transpose() * w * l.d_pose;
    }
    h
}

/// The observation of `map_plane` by the frame plane `seen`, weighed by the frame
/// plane's noise alone: the local BA's, where the map plane is a variable.
pub fn plane_observation(
    config: &PlaneTrackingConfig,
    seen: &Plane,
    map_plane: &MapPlane,
) -> PlaneObservation {
    let (inv_sigma2_normal, inv_sigma2_offset) = information(config, seen);
    PlaneObservation {
        normal_in_world: map_plane.normal,
        offset_in_world: map_plane.offset,
        measured: measured(seen),
        inv_sigma2_normal,
        inv_sigma2_offset,
    }
}

/// The observation of `map_plane` by the frame plane `seen` in tracking, where the map
/// plane is a constant: their difference carries the noise of both, the frame's and the
/// fused estimate's, taken as `n` observations as noisy as the frame's (`n` the
/// keyframes that see it): `sigma^2 (1 + 1/n)`. In the local BA the plane is a
/// variable, and each observation keeps its own noise ([`plane_observation`]).
fn tracking_observation(
    config: &PlaneTrackingConfig,
    seen: &Plane,
    map_plane: &MapPlane,
) -> PlaneObservation {
    let mut observation = plane_observation(config, seen, map_plane);
    let fused = map_plane.observations.len().max(1) as f64;
    let share = fused / (fused + 1.0);
    observation.inv_sigma2_normal *= share;
    observation.inv_sigma2_offset *= share;
    observation
}

/// Pairs frame planes with map planes, with reusable buffers.
#[derive(Debug, Default)]
pub struct PlaneAssociator {
    observations: Vec<PlaneObservation>,
    pairs: Vec<(usize, MapPlaneId)>,
    candidates: Vec<(f64, usize, MapPlaneId)>,
}

impl PlaneAssociator {
    /// The pairs of `planes` (seen from `camera_from_world`) with the planes of `map`,
    /// one map plane per frame plane and the reverse, closest first; the observations
    /// and the `(frame plane, map plane)` pairs in the same order.
    pub fn associate(
        &mut self,
        config: &PlaneTrackingConfig,
        planes: &[Plane],
        camera_from_world: &Isometry3<f64>,
        map: &Map,
    ) -> (&[PlaneObservation], &[(usize, MapPlaneId)]) {
        self.observations.clear();
        self.pairs.clear();
        self.candidates.clear();
        let min_cos = config.max_normal_angle_deg.to_radians().cos();
        let t = camera_from_world.translation.vector;
        for id in map.planes().ids() {
            let Some(map_plane) = map.plane(id) else {
                continue;
            };
            let n_c = camera_from_world.rotation * map_plane.normal;
            let d_c = map_plane.offset - n_c.dot(&t);
            for (i, plane) in planes.iter().enumerate() {
                let m = measured(plane);
                let cos = n_c.dot(&m.normal_in_camera);
                let offset = (d_c - m.offset).abs();
                if cos < min_cos || offset > config.max_offset_m {
                    continue;
                }
                // Angle and offset on one scale: each relative to its gate.
                let angle = cos.clamp(-1.0, 1.0).acos() / config.max_normal_angle_deg.to_radians();
                let cost = angle + offset / config.max_offset_m;
                self.candidates.push((cost, i, id));
            }
        }
        self.candidates
            .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        for &(_, i, id) in &self.candidates {
            if self.pairs.iter().any(|(j, other)| *j == i || *other == id) {
                continue;
            }
            let (Some(map_plane), Some(plane)) = (map.plane(id), planes.get(i)) else {
                continue;
            };
            self.pairs.push((i, id));
            self.observations
                .push(tracking_observation(config, plane, map_plane));
        }
        (&self.observations, &self.pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{CORNER, planes_of};

    #[test]
    fn each_frame_plane_pairs_with_its_map_plane_within_the_gates() {
        // A map of the corner's three planes and a frame 2-3 cm and 2 degrees from the
        // pose it is predicted at.
        let (map, _) = crate::testing::plane_map(&CORNER);
        let truth = gfs_core::se3::exp(&nalgebra::Vector6::new(
            0.03,
            0.02,
            -0.025,
            0.0,
            2f64.to_radians(),
            0.0,
        ));
        let planes = planes_of(&truth, &CORNER);
        let mut associator = PlaneAssociator::default();
        let config = PlaneTrackingConfig::default();
        let (observations, pairs) =
            associator.associate(&config, &planes, &Isometry3::identity(), &map);
        assert_eq!(observations.len(), 3);
        for (i, id) in pairs {
            let expected = map.plane(*id).expect("plane");
            let n = truth.inverse().rotation * measured(&planes[*i]).normal_in_camera;
            assert!((n - expected.normal).norm() < 1e-6, "{i}");
        }
        // A 1 cm offset gate pairs none of them.
        let tight = PlaneTrackingConfig {
            max_offset_m: 0.01,
            ..config
        };
        let (none, _) = associator.associate(&tight, &planes, &Isometry3::identity(), &map);
        assert!(none.is_empty());
    }

    #[test]
    fn a_map_plane_seen_by_fewer_keyframes_weighs_less_in_tracking() {
        let (mut map, kf) = crate::testing::plane_map(&CORNER);
        let config = PlaneTrackingConfig::default();
        let seen = &planes_of(&Isometry3::identity(), &CORNER)[0];
        let id = map.planes().ids().next().expect("a plane");
        let own = |map: &Map| plane_observation(&config, seen, map.plane(id).expect("plane"));
        let tracked =
            |map: &Map| tracking_observation(&config, seen, map.plane(id).expect("plane"));
        // One keyframe: the difference of two equally noisy planes, half the weight.
        assert_eq!(map.plane(id).expect("plane").observations.len(), 1);
        let ratio = tracked(&map).inv_sigma2_offset / own(&map).inv_sigma2_offset;
        assert!((ratio - 0.5).abs() < 1e-12, "{ratio}");
        // Three keyframes: the fused plane's variance is a third of one, 3/4 of the weight.
        let plane = map.plane_mut(id).expect("plane");
        plane.observations.push((kf, 7));
        plane.observations.push((kf, 8));
        let ratio = tracked(&map).inv_sigma2_normal / own(&map).inv_sigma2_normal;
        assert!((ratio - 0.75).abs() < 1e-12, "{ratio}");
    }
}
