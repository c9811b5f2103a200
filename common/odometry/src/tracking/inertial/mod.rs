//! The camera's IMU in the tracker. The samples a caller pushes wait in an
//! [`ImuStream`]; each frame is predicted from their preintegration since the last
//! frame: the rotation from the gyroscope from the start (better than the constant
//! velocity's), the whole pose once [`initialiser`] has found gravity, the velocity
//! and the biases from the first seconds of visual poses. After the frame is tracked,
//! [`fusion`] joins its visual pose (weighted by what its measurements determine) with
//! the inertial residual from the last frame's state: where the images leave a
//! direction free, the IMU carries it, and the covariance grows there as
//! preintegration says.

pub(crate) mod fusion;
mod initialiser;

use crate::tracking::status::TrackingStatus;
use fusion::{Matrix15, StepInput, VisualPose};
use gfs_core::stamp::Stamp;
use gfs_inertial::preintegration::Preintegrated;
use gfs_inertial::residual::State;
use gfs_inertial::{Bias, ImuConfig, ImuNoise, ImuSample, ImuStream, Pushed};
use initialiser::Initialiser;
use nalgebra::{Isometry3, Matrix6, Translation3, Vector3};

/// The most samples kept waiting for frames (5 s at 400 Hz).
const CAPACITY: usize = 2000;
/// Seconds a frame without any visual constraint is carried by the IMU alone and
/// published `degraded`; after that its pose is `predicted` (a consumer MEMS part's
/// accelerometer bias of 0.05 m/s^2 puts it 20 cm off in 3 s).
pub const CARRIED_S: f64 = 3.0;
/// Standard deviations of the state right after initialisation: the pose as the
/// visual poses' jitter, the velocity and biases as the initialisation's error on the
/// crate's tests (a few cm/s, 1e-3 rad/s, 0.05 m/s^2).
const INIT_SD: [f64; 5] = [0.002, 0.003, 0.05, 2e-3, 0.05];

/// Gravity and the last frame's state, once initialised.
#[derive(Clone, Debug)]
struct Filter {
    gravity: Vector3<f64>,
    state: State,
    covariance: Matrix15,
    /// Stamp of the last frame the images posed.
    last_seen: Stamp,
}

/// The last frame: its stamp and pose.
#[derive(Clone, Copy, Debug)]
struct LastFrame {
    stamp: Stamp,
    camera_from_world: Isometry3<f64>,
}

/// What the IMU made of a frame, after [`InertialTracker::finish`].
#[derive(Clone, Copy, Debug, Default)]
pub struct InertialOutcome {
    /// Covariance of the frame's `camera_from_world` with the IMU
    /// (`exp(delta) * pose`, `delta = [rho; phi]`), once initialised.
    pub covariance: Option<Matrix6<f64>>,
    /// The images gave no pose and the IMU carried it (within [`CARRIED_S`]).
    pub carried: bool,
}

/// The IMU's part of tracking.
pub struct InertialTracker {
    camera_from_imu: Isometry3<f64>,
    noise: ImuNoise,
    stream: ImuStream,
    /// Whether any sample came: without, every frame runs as without the IMU.
    seen_samples: bool,
    last: Option<LastFrame>,
    /// The preintegration from the last frame to the frame being tracked.
    pending: Option<Preintegrated>,
    /// Whether the last interval was covered (a change is warned about once).
    covered: bool,
    initialiser: Initialiser,
    filter: Option<Filter>,
    /// The gyroscope bias as last estimated (zero before initialisation).
    gyro_bias: Vector3<f64>,
}

impl InertialTracker {
    /// A tracker for an IMU mounted and specified as `config` says.
    pub fn new(config: &ImuConfig) -> Self {
        Self {
            camera_from_imu: config.camera_from_imu(),
            noise: config.noise(),
            stream: ImuStream::new(config.max_gap_s, CAPACITY),
            seen_samples: false,
            last: None,
            pending: None,
            covered: true,
            initialiser: Initialiser::default(),
            filter: None,
            gyro_bias: Vector3::zeros(),
        }
    }

    /// Adds a sample (camera clock).
    pub fn push(&mut self, sample: ImuSample) -> Pushed {
        let pushed = self.stream.push(sample);
        self.seen_samples |= !matches!(pushed, Pushed::Dropped(_));
        pushed
    }

    /// Whether gravity, velocity and biases are known.
    pub fn is_initialised(&self) -> bool {
        self.filter.is_some()
    }

    /// Gravity in the world, once initialised.
    pub fn gravity(&self) -> Option<Vector3<f64>> {
        self.filter.as_ref().map(|f| f.gravity)
    }

    /// The biases as estimated, once initialised.
    pub fn bias(&self) -> Option<Bias> {
        self.filter.as_ref().map(|f| f.state.bias)
    }

    /// The prediction (`camera_from_world`) of the frame at `stamp` from the samples
    /// since the last frame: the whole pose once initialised, else the gyroscope's
    /// rotation at the camera centre of `motion` (the motion model's prediction).
    /// `None` without samples covering the interval.
    pub fn predict(
        &mut self,
        stamp: Stamp,
        motion: Option<&Isometry3<f64>>,
    ) -> Option<Isometry3<f64>> {
        self.pending = None;
        let last = self.last?;
        if !self.seen_samples {
            return None;
        }
        let bias = self.filter.as_ref().map_or(
            Bias {
                gyro: self.gyro_bias,
                accel: Vector3::zeros(),
            },
            |f| f.state.bias,
        );
        let max_gap_s = self.stream.max_gap_s();
        let integrated = Preintegrated::between(
            self.stream.samples(),
            last.stamp,
            stamp,
            bias,
            self.noise,
            max_gap_s,
        );
        let pre = match integrated {
            Ok(pre) => pre,
            Err(e) => {
                if self.covered {
                    tracing::warn!("IMU: {e}: the frame at {stamp} is tracked without it");
                }
                self.covered = false;
                return None;
            }
        };
        if !self.covered {
            tracing::info!("IMU samples cover the frames again from {stamp}");
            self.covered = true;
        }
        let predicted = match &self.filter {
            Some(filter) => {
                let state = filter.state.predicted(&pre, &filter.gravity);
                fusion::camera_from_world(&state, &self.camera_from_imu)
            }
            None => {
                let world_from_camera = last.camera_from_world.inverse();
                let imu_turn = gfs_core::se3::rotation_from_matrix(&pre.delta_rotation(&bias));
                let imu = self.camera_from_imu.rotation;
                let rotation = world_from_camera.rotation * imu * imu_turn * imu.inverse();
                let centre = motion.map_or(world_from_camera.translation.vector, |m| {
                    m.inverse().translation.vector
                });
                Isometry3::from_parts(Translation3::from(centre), rotation).inverse()
            }
        };
        self.pending = Some(pre);
        Some(predicted)
    }

    /// Takes in the frame at `stamp`, tracked to `camera_from_world` with `status` and
    /// the `information` its measurements determine (`None` when the images did not
    /// pose it): once initialised its pose becomes the joint estimate with the IMU.
    pub fn finish(
        &mut self,
        stamp: Stamp,
        camera_from_world: &mut Isometry3<f64>,
        status: TrackingStatus,
        information: Option<&Matrix6<f64>>,
    ) -> InertialOutcome {
        let pre = self.pending.take();
        let measured = matches!(status, TrackingStatus::Tracked | TrackingStatus::Degraded);
        let information = information.filter(|_| measured);
        let mut outcome = InertialOutcome::default();
        if status == TrackingStatus::Relocalised {
            // The pose jumped to where the map says: the velocity means nothing now.
            self.filter = None;
        }
        match (&mut self.filter, pre) {
            (Some(filter), Some(pre)) => {
                let out = fusion::step(&StepInput {
                    preintegrated: &pre,
                    gravity: &filter.gravity,
                    last: &filter.state,
                    last_covariance: &filter.covariance,
                    visual: information.map(|information| VisualPose {
                        camera_from_world: *camera_from_world,
                        information,
                    }),
                    camera_from_imu: &self.camera_from_imu,
                });
                filter.state = out.state;
                filter.covariance = out.covariance;
                if information.is_some() {
                    filter.last_seen = stamp;
                }
                // A frame the images pose fully keeps their pose: joined with the IMU
                // on every frame, the synthetic rooms' ATE grew 3-6 times (the visual
                // poses' errors are correlated in time, the step takes them as
                // independent), so the joint estimate is published only where the
                // images leave a direction free or give nothing.
                if status != TrackingStatus::Tracked {
                    *camera_from_world =
                        fusion::camera_from_world(&out.state, &self.camera_from_imu);
                }
                self.gyro_bias = out.state.bias.gyro;
                outcome.covariance =
                    (status != TrackingStatus::Tracked).then_some(out.camera_covariance);
                outcome.carried =
                    information.is_none() && stamp.secs_since(filter.last_seen) <= CARRIED_S;
            }
            (Some(_), None) => {
                tracing::warn!(
                    "IMU: no samples for the frame at {stamp}: its state starts again from the next frames"
                );
                self.filter = None;
            }
            (None, pre) => {
                let pose = fusion::imu_pose(camera_from_world, &self.camera_from_imu);
                self.initialiser
                    .add(pose, pre, status == TrackingStatus::Tracked);
                if let Some(init) = self.initialiser.try_initialise() {
                    self.start(&init, pose, stamp);
                }
            }
        }
        self.last = Some(LastFrame {
            stamp,
            camera_from_world: *camera_from_world,
        });
        self.stream.discard_before(stamp);
        outcome
    }

    fn start(
        &mut self,
        init: &gfs_inertial::InertialInit,
        (rotation, position): (nalgebra::Matrix3<f64>, Vector3<f64>),
        stamp: Stamp,
    ) {
        let velocity = init.velocities.last().copied().unwrap_or_default();
        tracing::info!(
            gravity = ?init.gravity.as_slice(),
            gyro_bias = ?init.bias.gyro.as_slice(),
            accel_bias = ?init.bias.accel.as_slice(),
            speed = velocity.norm(),
            "IMU initialised"
        );
        let mut covariance = Matrix15::zeros();
        for (block, sd) in INIT_SD.iter().enumerate() {
            for k in 0..3 {
                covariance[(3 * block + k, 3 * block + k)] = sd * sd;
            }
        }
        self.gyro_bias = init.bias.gyro;
        self.filter = Some(Filter {
            gravity: init.gravity,
            state: State {
                rotation,
                position,
                velocity,
                bias: init.bias,
            },
            covariance,
            last_seen: stamp,
        });
    }

    /// Goes on from a frame the mapping half found at `camera_from_world`: the state
    /// starts again there (the velocity before the jump means nothing).
    pub fn relocalised(&mut self, stamp: Stamp, camera_from_world: &Isometry3<f64>) {
        self.filter = None;
        self.pending = None;
        self.last = Some(LastFrame {
            stamp,
            camera_from_world: *camera_from_world,
        });
    }

    /// Re-expresses the state in a corrected world (`new_from_old`, a loop
    /// correction): gravity and the velocity turn with it.
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        let turn = new_from_old.rotation.to_rotation_matrix().into_inner();
        if let Some(filter) = &mut self.filter {
            filter.gravity = turn * filter.gravity;
            filter.state.velocity = turn * filter.state.velocity;
            filter.state.rotation = turn * filter.state.rotation;
            filter.state.position =
                (new_from_old * nalgebra::Point3::from(filter.state.position)).coords;
        }
        if let Some(last) = &mut self.last {
            last.camera_from_world *= new_from_old.inverse();
        }
    }
}

#[cfg(test)]
mod tests;
