//! Synthetic fixtures shared by the integration tests and the benchmark example: a
//! PRNG, a camera, scenes of points and axis-aligned lines, noisy observations.
#![allow(dead_code)]

use gfs_core::camera::PinholeCamera;
use gfs_core::se3::exp;
use gfs_optim::{LineObservation, PointObservation};
use nalgebra::{Isometry3, Point3, Vector2, Vector3, Vector6};

/// [`gfs_core::rng::SplitMix64`] plus Box-Muller: deterministic random numbers.
pub struct Rng(gfs_core::rng::SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(gfs_core::rng::SplitMix64::new(seed))
    }

    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.range(lo, hi)
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        self.0.below(n as u64) as usize
    }

    pub fn gaussian(&mut self) -> f64 {
        let u1 = self.uniform(1e-12, 1.0);
        let u2 = self.uniform(0.0, 1.0);
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    pub fn gaussian3(&mut self, sigma: f64) -> Vector3<f64> {
        Vector3::new(self.gaussian(), self.gaussian(), self.gaussian()) * sigma
    }

    pub fn unit3(&mut self) -> Vector3<f64> {
        loop {
            let v = self.gaussian3(1.0);
            if v.norm() > 1e-6 {
                return v.normalize();
            }
        }
    }
}

/// A Kinect-like camera (TUM fr1 intrinsics rounded), 640x480.
pub fn camera() -> PinholeCamera {
    PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
}

/// The three Manhattan axes of the synthetic scenes.
pub const AXES: [Vector3<f64>; 3] = [
    Vector3::new(1.0, 0.0, 0.0),
    Vector3::new(0.0, 1.0, 0.0),
    Vector3::new(0.0, 0.0, 1.0),
];

/// `camera_from_world` moved by `translation` metres and `angle` radians in random
/// directions.
pub fn perturb(
    pose: &Isometry3<f64>,
    translation: f64,
    angle: f64,
    rng: &mut Rng,
) -> Isometry3<f64> {
    let t = rng.unit3() * translation;
    let r = rng.unit3() * angle;
    exp(&Vector6::new(t.x, t.y, t.z, r.x, r.y, r.z)) * pose
}

/// Distance between the camera centres (metres) and the rotation angle (degrees)
/// between two `camera_from_world` poses.
pub fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let ca = a.inverse().translation.vector;
    let cb = b.inverse().translation.vector;
    let dr = a.rotation * b.rotation.inverse();
    ((ca - cb).norm(), dr.angle().to_degrees())
}

/// The largest [`pose_error`] of `problem`'s poses against `truth`, pose by pose.
fn max_pose_error(problem: &gfs_optim::BaProblem, truth: &[Isometry3<f64>]) -> (f64, f64) {
    problem
        .poses
        .iter()
        .zip(truth)
        .map(|(p, t)| pose_error(&p.camera_from_world, t))
        .fold((0.0, 0.0), |(a, b), (c, d)| {
            (f64::max(a, c), f64::max(b, d))
        })
}

/// World point seen at pixel `uv` at `depth` by `camera_from_world`.
pub fn point_at_pixel(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    uv: Vector2<f64>,
    depth: f64,
) -> Vector3<f64> {
    let p_c = camera.back_project(uv.x, uv.y, depth);
    (camera_from_world.inverse() * p_c).coords
}

/// Pixel of a world point, if it projects inside the image with a 10 px border.
pub fn project(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    p_w: &Vector3<f64>,
) -> Option<Vector2<f64>> {
    let uv = camera.project(&(camera_from_world * Point3::from(*p_w)))?;
    camera.contains(uv.x, uv.y, 10.0).then_some(uv.coords)
}

/// Normalised line coefficients through two pixels (as `gfs_lines::Segment`).
pub fn line_through(a: Vector2<f64>, b: Vector2<f64>) -> Vector3<f64> {
    let d = b - a;
    let n = Vector2::new(d.y, -d.x) / d.norm();
    Vector3::new(n.x, n.y, -n.dot(&a))
}

/// A noisy observation of a world line: both endpoints inside the image, at least
/// 30 px long, each endpoint moved by `noise_px` Gaussian pixels.
pub fn observe_line(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    line: &[Vector3<f64>; 2],
    noise_px: f64,
    rng: &mut Rng,
) -> Option<Vector3<f64>> {
    let a = project(camera, camera_from_world, &line[0])?;
    let b = project(camera, camera_from_world, &line[1])?;
    if (a - b).norm() < 30.0 {
        return None;
    }
    let noise = |rng: &mut Rng| Vector2::new(rng.gaussian(), rng.gaussian()) * noise_px;
    Some(line_through(a + noise(rng), b + noise(rng)))
}

/// A line of `axis` direction, `length` metres, centred at `centre`.
pub fn axis_line(centre: Vector3<f64>, axis: usize, length: f64) -> [Vector3<f64>; 2] {
    let half = AXES[axis] * (0.5 * length);
    [centre - half, centre + half]
}

/// Angle in degrees between a line's direction and an axis (sign-free).
pub fn direction_error_deg(line: &[Vector3<f64>; 2], axis: &Vector3<f64>) -> f64 {
    let d = (line[1] - line[0]).normalize();
    d.dot(axis).abs().min(1.0).acos().to_degrees()
}

/// A synthetic local-BA scene: keyframes along a path looking at points and
/// axis-aligned lines, its true values and a noisy problem built from it.
pub struct BaScene {
    pub true_poses: Vec<Isometry3<f64>>,
    pub true_points: Vec<Vector3<f64>>,
    pub true_lines: Vec<[Vector3<f64>; 2]>,
    pub line_axis: Vec<usize>,
    pub problem: gfs_optim::BaProblem,
}

/// Options of [`BaScene::new`].
pub struct BaSceneSpec {
    pub keyframes: usize,
    pub points: usize,
    pub lines: usize,
    /// Leading keyframes held fixed (2 fix the scale, which 2D errors leave free).
    pub fixed: usize,
    /// Each point is observed only by the keyframes of a random window of this many
    /// consecutive keyframes (its track length); 0 = by every keyframe that sees it.
    pub track_window: usize,
    /// Parallel and perpendicular partners per line (each).
    pub partners: usize,
    /// Fraction of point observations replaced by a random pixel.
    pub outlier_ratio: f64,
    /// Points closer than this (metres, camera z) get a measured depth (Kinect-like
    /// noise); 0 for 2D observations only.
    pub depth_range: f64,
}

impl BaScene {
    pub fn new(spec: &BaSceneSpec, rng: &mut Rng) -> Self {
        use gfs_optim::{BaLineObservation, BaManhattan, BaPointObservation, BaPose, BaProblem};
        let camera = camera();
        let true_poses: Vec<Isometry3<f64>> = (0..spec.keyframes)
            .map(|k| {
                let s = k as f64 - 0.5 * (spec.keyframes as f64 - 1.0);
                let centre = Vector3::new(0.15 * s, 0.03 * (k as f64).sin(), 0.02 * s);
                let rotation = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::new(
                    0.01 * s,
                    -0.03 * s,
                    0.005 * s,
                ));
                Isometry3::from_parts(centre.into(), rotation).inverse()
            })
            .collect();
        let seen_by = |p: &Vector3<f64>| {
            true_poses
                .iter()
                .filter(|t| project(&camera, t, p).is_some())
                .count()
        };
        let n = spec.keyframes;
        let window = if spec.track_window == 0 {
            n
        } else {
            spec.track_window.min(n)
        };
        let tracked = |p: &Vector3<f64>, first: usize| {
            (first..first + window)
                .filter(|&k| project(&camera, &true_poses[k], p).is_some())
                .count()
        };
        let mut true_points = Vec::new();
        let mut track_start = Vec::new();
        while true_points.len() < spec.points {
            let p = Vector3::new(
                rng.uniform(-1.8, 1.8),
                rng.uniform(-1.3, 1.3),
                rng.uniform(1.5, 5.0),
            );
            let first = rng.below(n - window + 1);
            if tracked(&p, first) >= 2 {
                true_points.push(p);
                track_start.push(first);
            }
        }
        let mut true_lines = Vec::new();
        let mut line_axis = Vec::new();
        while true_lines.len() < spec.lines {
            let axis = true_lines.len() % 3;
            let centre = Vector3::new(
                rng.uniform(-1.5, 1.5),
                rng.uniform(-1.0, 1.0),
                rng.uniform(2.0, 4.5),
            );
            let line = axis_line(centre, axis, rng.uniform(0.4, 1.0));
            if seen_by(&line[0]).min(seen_by(&line[1])) >= 2 {
                true_lines.push(line);
                line_axis.push(axis);
            }
        }
        let mut problem = BaProblem::new(camera);
        for (k, t) in true_poses.iter().enumerate() {
            let fixed = k < spec.fixed;
            let camera_from_world = if fixed {
                *t
            } else {
                perturb(t, 0.03, 1f64.to_radians(), rng)
            };
            problem.poses.push(BaPose {
                camera_from_world,
                fixed,
            });
        }
        for (i, p) in true_points.iter().enumerate() {
            for (k, t) in true_poses.iter().enumerate() {
                if k < track_start[i] || k >= track_start[i] + window {
                    continue;
                }
                let Some(uv) = project(&camera, t, p) else {
                    continue;
                };
                let z = (t * Point3::from(*p)).z;
                let depth = if z < spec.depth_range {
                    z + rng.gaussian() * (0.0012 + 0.0019 * (z - 0.4) * (z - 0.4))
                } else {
                    0.0
                };
                let uv = if rng.uniform(0.0, 1.0) < spec.outlier_ratio {
                    {
                        let angle = rng.uniform(0.0, std::f64::consts::TAU);
                        uv + Vector2::new(angle.cos(), angle.sin()) * rng.uniform(20.0, 60.0)
                    }
                } else {
                    uv + Vector2::new(rng.gaussian(), rng.gaussian())
                };
                problem.point_observations.push(BaPointObservation {
                    pose: k,
                    point: i,
                    uv,
                    inv_sigma2: 1.0,
                    depth,
                });
            }
            problem.points.push(p + rng.gaussian3(0.03));
        }
        for (j, l) in true_lines.iter().enumerate() {
            for (k, t) in true_poses.iter().enumerate() {
                if let Some(coeffs) = observe_line(&camera, t, l, 1.0, rng) {
                    problem.line_observations.push(BaLineObservation {
                        pose: k,
                        line: j,
                        coeffs,
                        inv_sigma2: 1.0,
                    });
                }
            }
            problem
                .lines
                .push([l[0] + rng.gaussian3(0.03), l[1] + rng.gaussian3(0.03)]);
            problem.manhattan.push(BaManhattan {
                line: j,
                axis: AXES[line_axis[j]],
            });
        }
        let n = true_lines.len();
        for i in 0..n {
            // Lines i, i+3, i+6... share an axis; i+1, i+2 are perpendicular to i.
            for step in 1..=spec.partners {
                if i + 3 * step < n {
                    problem.parallel.push((i, i + 3 * step));
                }
                let other = i + (if step % 2 == 1 { 1 } else { 2 }) + 3 * ((step - 1) / 2);
                if other < n {
                    problem.perpendicular.push((i, other));
                }
            }
        }
        Self {
            true_poses,
            true_points,
            true_lines,
            line_axis,
            problem,
        }
    }

    /// Largest camera-centre error (m) and rotation error (deg) over the poses.
    pub fn max_pose_error(&self) -> (f64, f64) {
        max_pose_error(&self.problem, &self.true_poses)
    }

    /// The largest [`pose_error`] between this scene's estimated poses and `other`'s.
    pub fn max_pose_difference(&self, other: &BaScene) -> (f64, f64) {
        let others: Vec<_> = other
            .problem
            .poses
            .iter()
            .map(|p| p.camera_from_world)
            .collect();
        max_pose_error(&self.problem, &others)
    }

    /// Mean angle (deg) between the estimated lines and their true axes.
    pub fn mean_line_direction_error(&self) -> f64 {
        let sum: f64 = self
            .problem
            .lines
            .iter()
            .zip(&self.line_axis)
            .map(|(l, &a)| direction_error_deg(l, &AXES[a]))
            .sum();
        sum / self.problem.lines.len() as f64
    }

    /// RMS distance (m) of the estimated points to the true ones.
    pub fn point_rms(&self) -> f64 {
        let sum: f64 = self
            .problem
            .points
            .iter()
            .zip(&self.true_points)
            .map(|(p, t)| (p - t).norm_squared())
            .sum();
        (sum / self.true_points.len() as f64).sqrt()
    }
}

/// A frame's observations with the truth about which are outliers.
pub struct Frame {
    pub points: Vec<PointObservation>,
    pub lines: Vec<LineObservation>,
    pub point_outlier: Vec<bool>,
    pub line_outlier: Vec<bool>,
}

pub fn random_pixel(rng: &mut Rng) -> Vector2<f64> {
    Vector2::new(rng.uniform(10.0, 629.0), rng.uniform(10.0, 469.0))
}

/// `n_points` points and `n_lines` axis-aligned lines in view of `truth`, with outliers.
pub fn synthetic_frame(
    camera: &PinholeCamera,
    truth: &Isometry3<f64>,
    n_points: usize,
    n_lines: usize,
    outlier_ratio: f64,
    with_depth: bool,
    rng: &mut Rng,
) -> Frame {
    let mut frame = Frame {
        points: Vec::new(),
        lines: Vec::new(),
        point_outlier: Vec::new(),
        line_outlier: Vec::new(),
    };
    while frame.points.len() < n_points {
        let uv = random_pixel(rng);
        let z = rng.uniform(1.0, 6.0);
        let p_w = point_at_pixel(camera, truth, uv, z);
        let outlier = rng.uniform(0.0, 1.0) < outlier_ratio;
        let observed = if outlier {
            let mut wrong = random_pixel(rng);
            while (wrong - uv).norm() < 20.0 {
                wrong = random_pixel(rng);
            }
            wrong
        } else {
            uv + Vector2::new(rng.gaussian(), rng.gaussian())
        };
        // Kinect-like depth noise for points closer than 3.2 m (ORB-SLAM2 TUM ThDepth).
        let depth = if with_depth && z < 3.2 {
            z + rng.gaussian() * (0.0012 + 0.0019 * (z - 0.4) * (z - 0.4))
        } else {
            0.0
        };
        frame.points.push(PointObservation {
            point_in_world: p_w,
            uv: observed,
            inv_sigma2: 1.0,
            depth,
        });
        frame.point_outlier.push(outlier);
    }
    while frame.lines.len() < n_lines {
        let centre = point_at_pixel(camera, truth, random_pixel(rng), rng.uniform(1.5, 5.0));
        let line = axis_line(centre, frame.lines.len() % 3, rng.uniform(0.3, 1.2));
        let Some(coeffs) = observe_line(camera, truth, &line, 1.0, rng) else {
            continue;
        };
        let outlier = rng.uniform(0.0, 1.0) < outlier_ratio;
        let coeffs = if outlier {
            // A random image line that passes at least 20 px from the true endpoints.
            let ends = [
                project(camera, truth, &line[0]),
                project(camera, truth, &line[1]),
            ];
            loop {
                let c = line_through(random_pixel(rng), random_pixel(rng));
                let far = ends
                    .iter()
                    .flatten()
                    .any(|e| (c.x * e.x + c.y * e.y + c.z).abs() > 20.0);
                if far {
                    break c;
                }
            }
        } else {
            coeffs
        };
        frame.lines.push(LineObservation {
            endpoints_in_world: line,
            coeffs,
            inv_sigma2: 1.0,
        });
        frame.line_outlier.push(outlier);
    }
    frame
}
