//! `gfsvo synth`: render a synthetic RGB-D sequence with exact ground truth, in TUM
//! RGB-D layout, so that the project runs and is tested with no download.

use crate::CliResult;
use clap::{Args, ValueEnum};
use gfs_core::camera::DistortionModel;
use gfs_synth::{
    NoiseConfig, SceneKind, Sensor, SynthConfig, SynthImu, SynthSequence, TrajectoryKind,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// Widest image rendered (4K): the renderer holds a few full-size planes per frame.
const MAX_WIDTH: usize = 4096;
/// Longest sequence rendered: 10 minutes at 30 Hz.
const MAX_FRAMES: usize = 18_000;

/// Arguments of `gfsvo synth`.
#[derive(Args)]
#[command(after_help = "\
A procedural indoor Manhattan scene (walls, floor, ceiling, furniture, door / window / \
picture frames, objects rotated about the vertical, procedural textures) is ray cast \
along a smooth hand-held-like trajectory at 30 Hz. The output folder holds rgb/ and \
depth/ (16-bit PNG, 5000 units per metre), rgb.txt, depth.txt, associations.txt, \
groundtruth.txt (T_wc, timestamp tx ty tz qx qy qz qw) and synthetic.toml (the camera, \
which `gfsvo` picks up when it reads the folder).\n\n\
The same flags and seed always give the same images, bit for bit.\n\n\
Examples:\n  gfsvo synth                                   # room, slow, 300 frames, Kinect v1\n  \
gfsvo synth --sensor ideal                    # the tuned, independent noise\n  \
gfsvo synth --scene corridor --traj fast --frames 600 --seed 7\n  \
gfsvo synth --traj loop --frames 1081          # three laps of the room, back at the start\n  \
gfsvo synth --scene low-texture --clean --out /tmp/lowtex   # exact depth, clean colour\n  \
gfsvo synth --distortion rational_polynomial --out /tmp/azure  # as an Azure Kinect records\n  \
gfsvo synth --traj fast --imu --out /tmp/imu   # with a RealSense-like IMU at 200 Hz")]
pub struct SynthArgs {
    /// Scene: `room` (textured: bricks, posters, shelves, tiles), `low-texture` (plain
    /// walls, a few frames and boxes), `corridor` (14 m long, doors on both sides).
    #[arg(long, value_enum, default_value_t = SceneArg::Room)]
    scene: SceneArg,
    /// Camera motion: `slow` (~0.2 m/s, ~15 deg/s), `fast` (~0.6 m/s, ~45 deg/s),
    /// `rotation` (mostly rotation in place, ~40 deg/s, like TUM fr1_rpy), `loop` (laps
    /// around the room looking at the walls, one per 360 frames, ~0.4 m/s, 30 deg/s:
    /// every place is seen again a lap later; `--frames 1081` is three laps, back at the
    /// start).
    #[arg(long, value_enum, default_value_t = TrajArg::Slow)]
    traj: TrajArg,
    /// Number of frames (30 per second).
    #[arg(long, default_value_t = 300)]
    frames: usize,
    /// Seed of textures, trajectory and noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder [default: ./synth_<scene>_<traj>].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Image width in pixels; the height is 3/4 of it and the focal length scales with it
    /// (640 gives the camera of configs/synthetic.toml).
    #[arg(long, default_value_t = 640)]
    width: usize,
    /// The depth camera imitated: `kinect-v1` (structured light: 7.5 cm baseline,
    /// 580 px, disparity error correlated across the image and drifting, 1/8 px steps,
    /// projector shadows, dropouts at edges and grazing angles, auto-exposure,
    /// vignetting), `realsense` (D435-like active stereo: 50 mm, 0.08 px matching
    /// error), `tof` (time of flight: error proportional to depth, flying pixels at
    /// edges, no shadows), `ideal` (depth error independent from pixel to pixel and
    /// frame to frame, 1.425e-3 z^2 m, slow exposure drift: what configs/synthetic.toml
    /// and the end-to-end tests are tuned on).
    #[arg(long, value_enum, default_value_t = SensorArg::KinectV1)]
    sensor: SensorArg,
    /// The sensor's depth error [default].
    #[arg(long, overrides_with = "no_depth_noise")]
    depth_noise: bool,
    /// Exact depth (no noise, no quantisation in memory).
    #[arg(long, overrides_with = "depth_noise")]
    no_depth_noise: bool,
    /// Missing depth: random blobs, grazing angles, beyond the range, shadows and
    /// depth edges as the sensor has them [default].
    #[arg(long, overrides_with = "no_holes")]
    holes: bool,
    /// Depth everywhere a surface is hit.
    #[arg(long, overrides_with = "holes")]
    no_holes: bool,
    /// Standard deviation of gaussian image noise, in gray levels (0 = none) [default:
    /// the sensor's, 2 or 2.5].
    #[arg(long, value_name = "SIGMA")]
    image_noise: Option<f64>,
    /// Amplitude of a slow exposure (gain) drift, relative: 0.08 lets the gain wander
    /// within [0.92, 1.08]; 0 = none [default: 0.08 for `ideal`, 0 for the others,
    /// whose auto-exposure follows the scene].
    #[arg(long, value_name = "AMPLITUDE")]
    exposure: Option<f64>,
    /// No sensor effects at all: exact depth, clean constant images (whatever the
    /// sensor).
    #[arg(long)]
    clean: bool,
    /// Record the frames through a lens of this model, with the coefficients of a camera
    /// that has one (plumb_bob: TUM freiburg1; rational_polynomial: Azure Kinect;
    /// equidistant: a T265-like fisheye), written into synthetic.toml's `[camera]`.
    #[arg(long, value_parser = ["none", "plumb_bob", "rational_polynomial", "equidistant"], default_value = "none")]
    distortion: String,
    /// Also render the camera's IMU at this rate (Hz, 100-1000; 200 when given without
    /// a value) into imu.txt: a RealSense-D435i-like BMI055 (white noise and walking
    /// biases of the datasheet), 2 cm beside the colour camera with its own axes, its
    /// mount and noise written into synthetic.toml's `[imu]`.
    #[arg(long, num_args = 0..=1, default_missing_value = "200", value_name = "HZ")]
    imu: Option<f64>,
}

/// Scene names on the command line.
#[derive(Clone, Copy, ValueEnum)]
enum SceneArg {
    Room,
    LowTexture,
    Corridor,
}

/// Sensor names on the command line.
#[derive(Clone, Copy, ValueEnum)]
enum SensorArg {
    KinectV1,
    Realsense,
    Tof,
    Ideal,
}

/// Trajectory names on the command line.
#[derive(Clone, Copy, ValueEnum)]
enum TrajArg {
    Slow,
    Fast,
    Rotation,
    Loop,
}

impl SynthArgs {
    fn config(&self) -> CliResult<SynthConfig> {
        if !(16..=MAX_WIDTH).contains(&self.width) || !self.width.is_multiple_of(4) {
            return Err(format!(
                "--width {} must be a multiple of 4 in [16, {MAX_WIDTH}]",
                self.width
            )
            .into());
        }
        if !(1..=MAX_FRAMES).contains(&self.frames) {
            return Err(format!("--frames {} must be in [1, {MAX_FRAMES}]", self.frames).into());
        }
        let of_sensor = NoiseConfig::of(self.sensor.into());
        let image_sigma = self.image_noise.unwrap_or(of_sensor.image_sigma);
        let exposure = self.exposure.unwrap_or(of_sensor.exposure);
        if !(image_sigma >= 0.0 && image_sigma.is_finite()) {
            return Err(format!("--image-noise {image_sigma} must be >= 0").into());
        }
        if !(0.0..1.0).contains(&exposure) {
            return Err(format!("--exposure {exposure} must be in [0, 1)").into());
        }
        if let Some(rate) = self.imu
            && !(100.0..=1000.0).contains(&rate)
        {
            return Err(format!("--imu {rate} Hz must be in [100, 1000]").into());
        }
        let noise = if self.clean {
            NoiseConfig::none()
        } else {
            NoiseConfig {
                depth_noise: !self.no_depth_noise,
                holes: !self.no_holes,
                image_sigma,
                exposure,
                ..of_sensor
            }
        };
        Ok(SynthConfig {
            scene: match self.scene {
                SceneArg::Room => SceneKind::Room,
                SceneArg::LowTexture => SceneKind::LowTexture,
                SceneArg::Corridor => SceneKind::Corridor,
            },
            trajectory: match self.traj {
                TrajArg::Slow => TrajectoryKind::Slow,
                TrajArg::Fast => TrajectoryKind::Fast,
                TrajArg::Rotation => TrajectoryKind::Rotation,
                TrajArg::Loop => TrajectoryKind::Loop,
            },
            frames: self.frames,
            seed: self.seed,
            noise,
            camera: SynthConfig::scaled_camera(self.width),
            distortion: DistortionModel::from_name(&self.distortion)
                .map(gfs_synth::typical_lens)
                .unwrap_or_default(),
            imu: self.imu.map(SynthImu::realsense_like),
            ..SynthConfig::default()
        })
    }
}

/// Runs `gfsvo synth`.
pub fn run(args: &SynthArgs) -> CliResult {
    let config = args.config()?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("synth_{}_{}", config.scene, config.trajectory)));
    let started = Instant::now();
    let sequence = SynthSequence::new(config);
    let bar = ProgressBar::new(sequence.len() as u64).with_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}",
        )
        .map_err(|e| e.to_string())?
        .progress_chars("=> "),
    );
    sequence.write_tum(&out, |done| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    let c = sequence.config();
    println!(
        "wrote {} frames ({}x{}, scene {}, trajectory {}, sensor {}, seed {}) to {} in {seconds:.1} s ({:.1} ms/frame)",
        sequence.len(),
        c.camera.width,
        c.camera.height,
        c.scene,
        c.trajectory,
        if args.clean {
            "clean"
        } else {
            Sensor::from(args.sensor).name()
        },
        c.seed,
        out.display(),
        1000.0 * seconds / sequence.len().max(1) as f64,
    );
    Ok(())
}

impl From<SensorArg> for Sensor {
    fn from(sensor: SensorArg) -> Self {
        match sensor {
            SensorArg::KinectV1 => Sensor::KinectV1,
            SensorArg::Realsense => Sensor::RealSense,
            SensorArg::Tof => Sensor::Tof,
            SensorArg::Ideal => Sensor::Ideal,
        }
    }
}
