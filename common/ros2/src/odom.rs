//! Poses of the camera as ROS 2 odometry (REP 103 / 105): the pipeline's world is the
//! first camera frame, so `odom` is the base frame at the first image and the pose of the
//! base is `B * T_wc * B^-1` with `B` the camera in the base. The covariance of the
//! tracker's pose (6x6 over a perturbation of the camera frame, translation then
//! rotation) becomes the covariance of the base pose in the base frame's axes
//! (`Ad(B) C Ad(B)^T`).

use crate::config::{Ros2Config, WhenLost};
use crate::msg::{
    Header, Odometry, Pose, PoseWithCovariance, Quaternion, StringMsg, TfMessage, Time, Transform,
    TransformStamped, Twist, TwistWithCovariance, Vector3,
};
use gfs_core::stamp::Stamp;
use nalgebra::{Isometry3, Matrix6, Quaternion as NaQuaternion, Translation3, UnitQuaternion};

/// One frame's output of the tracker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackedPose {
    /// The colour image's stamp, as received.
    pub stamp: Stamp,
    /// Camera in the pipeline's world (first camera frame).
    pub world_from_camera: Isometry3<f64>,
    /// Covariance of the pose (camera-frame perturbation: translation, rotation), if the
    /// optimisation gave one.
    pub covariance: Option<Matrix6<f64>>,
    /// `tracked`, `degraded`, `predicted`, `relocalised`.
    pub status: &'static str,
    /// The loop corrections so far in the pipeline's world (`map_from_odom`; the
    /// identity until a loop closes).
    pub map_from_odom: Isometry3<f64>,
}

/// Covariance published when the optimisation gave none (a predicted frame): 1 m and
/// 1 rad standard deviation before `lost_covariance_scale`, i.e. "do not trust".
const UNKNOWN_VARIANCE: f64 = 1.0;

/// Turns tracked poses into `/odom`, `/tf` and status messages (keeps the previous pose
/// for the twist).
pub struct OdometryPublisherState {
    config: Ros2Config,
    camera_in_base: Isometry3<f64>,
    previous: Option<(Stamp, Isometry3<f64>, Matrix6<f64>)>,
}

/// The messages of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMessages {
    /// `/odom`, `None` when lost and `when_lost = "nothing"`.
    pub odometry: Option<Odometry>,
    /// `/tf` (odom -> base, and map -> odom once a loop closed), when `publish_tf` and
    /// there is an odometry.
    pub tf: Option<TfMessage>,
    /// Status text.
    pub status: StringMsg,
}

impl OdometryPublisherState {
    /// The converter for `config` (validated first).
    pub fn new(config: &Ros2Config) -> Self {
        let c = config.camera_in_base;
        let rotation = UnitQuaternion::from_quaternion(NaQuaternion::new(c[6], c[3], c[4], c[5]));
        Self {
            config: config.clone(),
            camera_in_base: Isometry3::from_parts(Translation3::new(c[0], c[1], c[2]), rotation),
            previous: None,
        }
    }

    /// The pose of the base in `odom` for a camera pose in the pipeline's world.
    pub fn base_in_odom(&self, world_from_camera: &Isometry3<f64>) -> Isometry3<f64> {
        self.camera_in_base * world_from_camera * self.camera_in_base.inverse()
    }

    /// The camera pose in the pipeline's world for a base pose in `odom` (the inverse
    /// of [`Self::base_in_odom`]).
    pub fn camera_in_odom(&self, base_in_odom: &Isometry3<f64>) -> Isometry3<f64> {
        self.camera_in_base.inverse() * base_in_odom * self.camera_in_base
    }

    /// The odometry and map frame names.
    pub fn frames(&self) -> (&str, &str) {
        (&self.config.odom_frame, &self.config.map_frame)
    }

    /// The covariance of the base pose (base-frame axes) for a camera-frame covariance.
    pub fn base_covariance(&self, camera: &Matrix6<f64>) -> Matrix6<f64> {
        let ad = gfs_core::se3::adjoint(&self.camera_in_base);
        ad * camera * ad.transpose()
    }

    /// The messages of one frame.
    pub fn messages(&mut self, pose: &TrackedPose) -> FrameMessages {
        let status = StringMsg {
            data: pose.status.to_owned(),
        };
        let lost = pose.status == "predicted";
        if lost && self.config.when_lost == WhenLost::Nothing {
            return FrameMessages {
                odometry: None,
                tf: None,
                status,
            };
        }
        let base = self.base_in_odom(&pose.world_from_camera);
        let mut covariance = pose.covariance.map_or_else(
            || Matrix6::identity() * UNKNOWN_VARIANCE,
            |c| self.base_covariance(&c),
        );
        if lost {
            covariance *= self.config.lost_covariance_scale;
        }
        let twist = match self.previous {
            Some((t0, p0, c0)) if pose.stamp > t0 => {
                let dt = pose.stamp.secs_since(t0);
                let motion = gfs_core::se3::log(&(p0.inverse() * base)) / dt;
                // Two independent pose errors over dt (first order).
                let cov = (covariance + c0) / (dt * dt);
                (motion, cov)
            }
            _ => (
                nalgebra::Vector6::zeros(),
                Matrix6::identity() * UNKNOWN_VARIANCE,
            ),
        };
        self.previous = Some((pose.stamp, base, covariance));
        let header = Header {
            stamp: Time::from(pose.stamp),
            frame_id: self.config.odom_frame.clone(),
        };
        let transform = to_transform(&base);
        let odometry = Odometry {
            header: header.clone(),
            child_frame_id: self.config.base_frame.clone(),
            pose: PoseWithCovariance {
                pose: Pose {
                    position: transform.translation,
                    orientation: transform.rotation,
                },
                covariance: row_major(&covariance),
            },
            twist: TwistWithCovariance {
                twist: Twist {
                    linear: vector(twist.0[0], twist.0[1], twist.0[2]),
                    angular: vector(twist.0[3], twist.0[4], twist.0[5]),
                },
                covariance: row_major(&twist.1),
            },
        };
        let tf = self.config.publish_tf.then(|| {
            let mut transforms = vec![TransformStamped {
                header: header.clone(),
                child_frame_id: self.config.base_frame.clone(),
                transform,
            }];
            if pose.map_from_odom != Isometry3::identity() {
                // The same change of axes as the poses: odom is the base at the first
                // image, and so is map before any correction.
                let b = self.camera_in_base;
                transforms.push(TransformStamped {
                    header: Header {
                        frame_id: self.config.map_frame.clone(),
                        ..header
                    },
                    child_frame_id: self.config.odom_frame.clone(),
                    transform: to_transform(&(b * pose.map_from_odom * b.inverse())),
                });
            }
            TfMessage { transforms }
        });
        FrameMessages {
            odometry: Some(odometry),
            tf,
            status,
        }
    }
}

fn vector(x: f64, y: f64, z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

/// A pose as a ROS transform.
pub fn to_transform(pose: &Isometry3<f64>) -> Transform {
    let t = pose.translation.vector;
    let q = pose.rotation.quaternion();
    Transform {
        translation: vector(t.x, t.y, t.z),
        rotation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

/// A ROS pose as an isometry (the quaternion normalised).
pub fn from_pose(pose: &Pose) -> Isometry3<f64> {
    let q = &pose.orientation;
    let p = &pose.position;
    Isometry3::from_parts(
        Translation3::new(p.x, p.y, p.z),
        UnitQuaternion::from_quaternion(NaQuaternion::new(q.w, q.x, q.y, q.z)),
    )
}

fn row_major(m: &Matrix6<f64>) -> [f64; 36] {
    std::array::from_fn(|i| m[(i / 6, i % 6)])
}

#[cfg(test)]
#[path = "odom_tests.rs"]
mod tests;
