//! Smooth hand-held-like camera trajectories inside a scene's free space.
//!
//! Model: every degree of freedom is a sum of three sinusoids with seeded frequencies
//! and phases and weights summing to one, so it stays within `[-1, 1]`; the position is
//! the centre of [`Scene::free_space`] plus those sums times its half extents (so the
//! camera never leaves the free box, which keeps [`MIN_CLEARANCE`] from every surface),
//! and the orientation is yaw / pitch / roll about a base direction that looks along a
//! wall normal into the room. A small fixed-frequency tremor adds hand shake. The time
//! scale of the translation and of the rotation is then solved (fixed point) so that the
//! mean speeds over the frames match the kind's targets.
//!
//! [`MIN_CLEARANCE`]: crate::MIN_CLEARANCE

use crate::circuit;
use crate::rng::SplitMix64;
use crate::scene::Scene;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use std::f64::consts::TAU;
use std::fmt;

/// Which motion to generate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrajectoryKind {
    /// Walking pace, slow turns: about 0.2 m/s and 15 deg/s (default).
    #[default]
    Slow,
    /// Brisk hand-held motion: about 0.6 m/s and 45 deg/s.
    Fast,
    /// Mostly rotation in place (like TUM fr1_rpy): about 0.05 m/s and 40 deg/s.
    Rotation,
    /// Laps around the room looking at the walls, one every 12 s (360 frames at 30 Hz):
    /// about 0.4 m/s and 30 deg/s; every place is seen again a lap later
    /// ([`crate::circuit`]).
    Loop,
}

impl TrajectoryKind {
    /// All kinds, in CLI order.
    pub const ALL: [TrajectoryKind; 4] = [
        TrajectoryKind::Slow,
        TrajectoryKind::Fast,
        TrajectoryKind::Rotation,
        TrajectoryKind::Loop,
    ];

    /// The CLI / folder name (`slow`, `fast`, `rotation`, `loop`).
    pub fn name(self) -> &'static str {
        match self {
            TrajectoryKind::Slow => "slow",
            TrajectoryKind::Fast => "fast",
            TrajectoryKind::Rotation => "rotation",
            TrajectoryKind::Loop => "loop",
        }
    }

    /// Target mean translational (m/s) and angular (deg/s) speed.
    pub fn mean_speeds(self) -> (f64, f64) {
        match self {
            TrajectoryKind::Slow => (0.2, 15.0),
            TrajectoryKind::Fast => (0.6, 45.0),
            TrajectoryKind::Rotation => (0.05, 40.0),
            TrajectoryKind::Loop => circuit::MEAN_SPEEDS,
        }
    }

    /// Yaw, pitch and roll amplitudes (radians) of the orientation sums, and the
    /// fraction of the free-space half extents the position sums span.
    fn amplitudes(self) -> ([f64; 3], f64) {
        match self {
            // Loop has its own shape (crate::circuit); these are not used for it.
            TrajectoryKind::Slow | TrajectoryKind::Fast | TrajectoryKind::Loop => {
                ([0.9, 0.2, 0.06], 1.0)
            }
            TrajectoryKind::Rotation => ([0.6, 0.35, 0.4], 0.15),
        }
    }
}

impl fmt::Display for TrajectoryKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Camera pitch about which the pitch sum oscillates: slightly down, as people hold a
/// camera (radians, positive = down).
const BASE_PITCH: f64 = 0.12;
/// Hand tremor: amplitude (metres, radians) and frequencies (Hz).
const TREMOR_M: f64 = 0.002;
const TREMOR_RAD: f64 = 0.002;
const TREMOR_HZ: [f64; 2] = [1.3, 2.1];
/// Weights of the three sinusoids of every sum (they add up to 1).
const WEIGHTS: [f64; 3] = [0.55, 0.3, 0.15];
/// Base frequencies (Hz) of the three sinusoids, before the solved time scale.
const BASE_HZ: [f64; 3] = [0.05, 0.11, 0.23];
/// Bisection steps of the time-scale solve over [`TIME_SCALE_RANGE`] (log scale):
/// 2^-40 of six decades is far below 0.1 %.
const SPEED_ITERATIONS: usize = 40;
/// Time scales searched: from a thousand times slower to a thousand times faster.
const TIME_SCALE_RANGE: [f64; 2] = [1e-3, 1e3];

/// One degree of freedom: `sum_k w_k sin(2 pi f_k tau + phase_k)`, within [-1, 1].
#[derive(Clone, Copy, Debug)]
struct Wave {
    hz: [f64; 3],
    phase: [f64; 3],
}

impl Wave {
    fn new(rng: &mut SplitMix64) -> Self {
        Self {
            hz: BASE_HZ.map(|f| f * rng.range(0.85, 1.15)),
            phase: [0; 3].map(|_| rng.range(0.0, TAU)),
        }
    }

    fn at(&self, tau: f64) -> f64 {
        (0..3)
            .map(|k| WEIGHTS[k] * (TAU * self.hz[k] * tau + self.phase[k]).sin())
            .sum()
    }
}

/// The seeded shape of a trajectory before its time scales are solved.
#[derive(Clone, Debug)]
pub(crate) struct Shape {
    centre: Vector3<f64>,
    half: Vector3<f64>,
    position: [Wave; 3],
    angles: [Wave; 3],
    amplitudes: [f64; 3],
    base_yaw: f64,
    tremor_phase: [f64; 6],
}

impl Shape {
    fn position(&self, t: f64, time_scale: f64) -> Vector3<f64> {
        let tau = t * time_scale;
        let (shake, _) = tremor(&self.tremor_phase, t);
        let mut p = self.centre;
        for k in 0..3 {
            p[k] += self.half[k] * self.position[k].at(tau) + shake[k];
        }
        p
    }

    fn rotation(&self, t: f64, time_scale: f64) -> UnitQuaternion<f64> {
        let tau = t * time_scale;
        let angle = |k: usize| {
            self.amplitudes[k] * self.angles[k].at(tau)
                + TREMOR_RAD * (TAU * TREMOR_HZ[k % 2] * t + self.tremor_phase[3 + k]).sin()
        };
        let body = UnitQuaternion::from_euler_angles(
            angle(2),
            BASE_PITCH + angle(1),
            self.base_yaw + angle(0),
        );
        body * camera_in_body()
    }
}

/// Camera axes in the body frame (x forward, y left, z up): camera x = right = -y,
/// camera y = down = -z, camera z = forward = x.
fn camera_in_body() -> UnitQuaternion<f64> {
    let m = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

/// A camera motion defined at every instant, so that an IMU can be sampled from it
/// between the frames.
#[derive(Clone, Debug)]
pub(crate) enum Motion {
    /// Sums of sinusoids ([`TrajectoryKind::Slow`], `Fast`, `Rotation`) with their
    /// solved time scales.
    Waves {
        shape: Box<Shape>,
        translation_scale: f64,
        rotation_scale: f64,
    },
    /// Laps of [`crate::circuit`].
    Circuit(circuit::Lap),
}

impl Motion {
    /// The pose `T_wc` at `t` seconds after the first frame.
    pub(crate) fn pose(&self, t: f64) -> Isometry3<f64> {
        match self {
            Motion::Waves {
                shape,
                translation_scale,
                rotation_scale,
            } => Isometry3::from_parts(
                Translation3::from(shape.position(t, *translation_scale)),
                shape.rotation(t, *rotation_scale),
            ),
            Motion::Circuit(lap) => lap.pose(t),
        }
    }
}

/// The hand tremor shared by every kind at `t`: translation, and yaw / pitch / roll.
pub(crate) fn tremor(phase: &[f64; 6], t: f64) -> (Vector3<f64>, [f64; 3]) {
    let at = |k: usize| (TAU * TREMOR_HZ[k % 2] * t + phase[k]).sin();
    (
        Vector3::new(at(0), at(1), at(2)) * TREMOR_M,
        [at(3), at(4), at(5)].map(|x| x * TREMOR_RAD),
    )
}

/// The motion of `kind` in `scene`, deterministic for `seed`; the speeds are those of
/// `frames` frames at `rate_hz`.
pub(crate) fn motion(
    scene: &Scene,
    kind: TrajectoryKind,
    frames: usize,
    seed: u64,
    rate_hz: f64,
) -> Motion {
    let mut rng = SplitMix64::keyed(seed, &[0x0072_616a, kind as u64]);
    if kind == TrajectoryKind::Loop {
        let phase = [0; 6].map(|_| rng.range(0.0, TAU));
        return Motion::Circuit(circuit::Lap::new(
            scene,
            seed,
            camera_in_body(),
            BASE_PITCH,
            phase,
        ));
    }
    let free = scene.free_space();
    let (amplitudes, spread) = kind.amplitudes();
    // Keep the tremor inside the free box too.
    let half = free.half_extents().map(|h| (h - 2.0 * TREMOR_M).max(0.0));
    let yaws = &scene.base_yaws;
    let base_yaw = yaws[rng.below(yaws.len() as u64) as usize] + rng.range(-0.3, 0.3);
    let shape = Shape {
        centre: free.center().coords,
        half: half * spread,
        position: [0; 3].map(|_| Wave::new(&mut rng)),
        angles: [0; 3].map(|_| Wave::new(&mut rng)),
        amplitudes,
        base_yaw,
        tremor_phase: [0; 6].map(|_| rng.range(0.0, TAU)),
    };
    let dt = 1.0 / rate_hz;
    let times: Vec<f64> = (0..frames).map(|i| i as f64 * dt).collect();
    let (target_speed, target_deg) = kind.mean_speeds();
    let translation_scale = solve_time_scale(target_speed, |scale| {
        mean_rate(&times, |a, b| {
            (shape.position(b, scale) - shape.position(a, scale)).norm()
        })
    });
    let rotation_scale = solve_time_scale(target_deg.to_radians(), |scale| {
        mean_rate(&times, |a, b| {
            shape.rotation(a, scale).angle_to(&shape.rotation(b, scale))
        })
    });
    Motion::Waves {
        shape: Box::new(shape),
        translation_scale,
        rotation_scale,
    }
}

/// Mean of `step(t_i, t_i+1) / dt` over consecutive times; 0 with fewer than two.
fn mean_rate(times: &[f64], step: impl Fn(f64, f64) -> f64) -> f64 {
    if times.len() < 2 {
        return 0.0;
    }
    let total: f64 = times
        .windows(2)
        .map(|w| step(w[0], w[1]) / (w[1] - w[0]))
        .sum();
    total / (times.len() - 1) as f64
}

/// The time scale `s` with `rate(s) = target`, by bisection on `log s` (the rate grows
/// with `s`; near-proportional, but not exactly, as a faster clock also moves the
/// window of the frames along the curve). 1 when the rate cannot be measured.
fn solve_time_scale(target: f64, rate: impl Fn(f64) -> f64) -> f64 {
    let [mut lo, mut hi] = TIME_SCALE_RANGE.map(f64::ln);
    let fastest = rate(hi.exp());
    if fastest.is_nan() || fastest <= target {
        return 1.0; // fewer than two frames, or an unreachable target
    }
    for _ in 0..SPEED_ITERATIONS {
        let mid = 0.5 * (lo + hi);
        if rate(mid.exp()) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
}
