//! The Manhattan axes of the world: set from the first confident frame observation
//! (camera-frame axes rotated into the world), then the mean of every observation.
//! Map lines and planes are tied to these axes (paper eq. 14). The axes are a fixed
//! property of the world: a mean that forgot old observations would follow the poses'
//! drift, and tie the map to it.

use gfs_planes::ManhattanAxes;
use nalgebra::{Isometry3, Matrix3, Rotation3, Vector3};

/// Confidence a frame's axes need to found the world axes.
const MIN_CONFIDENCE: f32 = 0.5;
/// A camera axis refines the world axis it is within this angle of (radians, ~10 deg).
const MATCH_COS: f64 = 0.985;

/// The world Manhattan frame, if the scene has shown one.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct WorldManhattan {
    axes: Option<Rotation3<f64>>,
    /// Per world axis, the observations its direction averages.
    #[serde(default)]
    observations: [u32; 3],
    enabled: bool,
}

impl WorldManhattan {
    /// A world frame that learns its axes when `enabled` (the MA ablation switch).
    pub fn new(enabled: bool) -> Self {
        Self {
            axes: None,
            observations: [0; 3],
            enabled,
        }
    }

    /// The world axes (columns), once known.
    pub fn axes(&self) -> Option<&Rotation3<f64>> {
        self.axes.as_ref()
    }

    /// Takes in the axes a frame saw (camera frame), with that frame's pose.
    pub fn observe(&mut self, world_from_camera: &Isometry3<f64>, observed: &ManhattanAxes) {
        if !self.enabled || observed.confidence < MIN_CONFIDENCE {
            return;
        }
        let rotation = world_from_camera.rotation.to_rotation_matrix();
        let in_world = rotation * observed.rotation;
        let Some(axes) = &mut self.axes else {
            if observed.observed.iter().filter(|o| **o).count() >= 2 {
                self.axes = Some(in_world);
                self.observations = [1; 3];
            }
            return;
        };
        let mut m: Matrix3<f64> = *axes.matrix();
        for (k, seen) in observed.observed.iter().enumerate() {
            if !seen {
                continue;
            }
            let dir = in_world.matrix().column(k).into_owned();
            for (mut column, count) in m.column_iter_mut().zip(&mut self.observations) {
                let dot = column.dot(&dir);
                if dot.abs() > MATCH_COS {
                    *count += 1;
                    let rate = 1.0 / f64::from(*count);
                    let blended = column.clone_owned() * (1.0 - rate) + dir * (dot.signum() * rate);
                    column.copy_from(&blended);
                }
            }
        }
        *axes = gfs_core::se3::rotation_from_matrix(&m).to_rotation_matrix();
    }

    /// The axis (0, 1, 2) that `direction` (world) is parallel to within `max_angle`
    /// radians, if the axes are known.
    pub fn axis_of(&self, direction: &Vector3<f64>, max_angle: f64) -> Option<u8> {
        let axes = self.axes.as_ref()?;
        let d = direction.try_normalize(1e-12)?;
        let min_cos = max_angle.cos();
        (0..3u8).find(|&k| axes.matrix().column(k as usize).dot(&d).abs() >= min_cos)
    }

    /// The unit world direction of axis `k`.
    pub fn axis(&self, k: u8) -> Option<Vector3<f64>> {
        self.axes
            .as_ref()
            .map(|a| a.matrix().column(k as usize).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    fn seen(rotation: Rotation3<f64>, confidence: f32) -> ManhattanAxes {
        ManhattanAxes {
            rotation,
            observed: [true, true, false],
            support: [0.5, 0.4, 0.0],
            confidence,
        }
    }

    #[test]
    fn the_first_confident_frame_sets_the_world_axes_in_the_world_frame() {
        let mut world = WorldManhattan::new(true);
        let world_from_camera = Isometry3::from_parts(
            Translation3::new(1.0, 0.0, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.3, 0.0),
        );
        world.observe(&world_from_camera, &seen(Rotation3::identity(), 0.2));
        assert!(world.axes().is_none(), "not confident enough");
        world.observe(&world_from_camera, &seen(Rotation3::identity(), 0.9));
        let axes = world.axes().expect("set");
        assert!(axes.angle_to(&world_from_camera.rotation.to_rotation_matrix()) < 1e-7);
        // A direction along axis 0 within the angle is tied to it; a diagonal is not.
        let x = world.axis(0).expect("axis 0");
        assert_eq!(world.axis_of(&(x * 2.0), 0.1), Some(0));
        let diagonal = x + world.axis(1).expect("axis 1");
        assert_eq!(world.axis_of(&diagonal, 0.1), None);
    }

    #[test]
    fn the_axes_are_the_mean_of_every_observation_and_a_disabled_world_learns_nothing() {
        // 101 frames whose poses drift by 1 mrad a frame about z: the axes they see in
        // the world turn from 0 to 0.1 rad. The world's axes are their mean (0.05 rad),
        // not the last ones (a forgetting rate of 0.05 would end at 0.08 rad).
        let mut world = WorldManhattan::new(true);
        for k in 0..=100 {
            let drift = Rotation3::from_euler_angles(0.0, 0.0, 0.001 * f64::from(k));
            world.observe(&Isometry3::identity(), &seen(drift, 0.9));
        }
        let angle = world.axes().expect("set").angle();
        assert!((angle - 0.05).abs() < 1e-3, "{angle}");
        let mut off = WorldManhattan::new(false);
        off.observe(&Isometry3::identity(), &seen(Rotation3::identity(), 0.9));
        assert!(off.axes().is_none());
    }
}
