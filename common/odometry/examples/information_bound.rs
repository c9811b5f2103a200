//! The best any tracker could do on the frames of a synthetic sequence: the Cramér-Rao
//! bound of a frame's pose against a reference seen from the same place, from every
//! pixel's intensity and depth with the noise `gfsvo synth` renders (independent from
//! pixel to pixel: 2 gray levels per colour channel, depth sigma 1.425e-3 z^2 m, both
//! images noisy). A frame whose bound leaves a direction above `[tracking.depth]
//! max_sigma_m` cannot be tracked to that from its images, whatever the tracker does.
//!
//! The derivatives of the images with respect to the pose come from renders at poses
//! moved by +-1 mm and +-0.5 mrad (central differences of the unquantised luma and the
//! exact depth); pixels at an occlusion edge (depth jumping by more than 5 cm there) are
//! left out, and so are the depth's holes' losses: the bound is optimistic.
//!
//! Per frame it prints the worst direction's standard deviation, metres at the 2 m lever
//! arm (as the tracker's status does), for the depth alone, with the intensities at a
//! known exposure gain, and with the gain unknown (fitted per frame, as the tracker's
//! photometric term does: a smooth shading's shift then looks like a gain change).
//!
//! With `--cell N` the intensities are the means of N x N pixel cells (a cell with an
//! occlusion edge or a hole is left out), as a tracker that samples block means sees
//! them: what the bound loses from 1 to N is what the texture finer than N pixels holds.
//!
//! ```text
//! cargo run --release -p gfs-odometry --example information_bound -- \
//!     --scene low-texture --traj slow --seed 5 --frames 120 [--from 60] [--to 100] \
//!     [--step 2] [--cell 8] [--status out/status.txt]
//! ```

use gfs_core::camera::PinholeCamera;
use gfs_core::se3;
use gfs_optim::analyse_constraint;
use gfs_synth::{
    DEPTH_SIGMA_PER_Z2, LUMA_WEIGHTS, NoiseConfig, SceneKind, SynthConfig, SynthSequence,
    TrajectoryKind, render_luma_view,
};
use nalgebra::{Isometry3, Matrix6, SMatrix, SVector, Vector6};
use std::collections::HashMap;
use std::process::ExitCode;

/// Lever arm and threshold of the tracker's status (`[tracking.depth]` defaults).
const LEVER_ARM_M: f64 = 2.0;
const MAX_SIGMA_M: f64 = 0.015;
/// Pose steps of the central differences: metres, radians.
const STEP_M: f64 = 1e-3;
const STEP_RAD: f64 = 5e-4;
/// A pixel whose depth moves more than this between the two renders of a step is at an
/// occlusion edge, where the images are not differentiable.
const EDGE_JUMP_M: f32 = 0.05;

struct Args {
    config: SynthConfig,
    from: usize,
    to: usize,
    step: usize,
    cell: usize,
    status: Option<String>,
}

fn main() -> ExitCode {
    match parse(std::env::args().skip(1)).and_then(|args| run(&args)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("information_bound: {e}");
            ExitCode::from(2)
        }
    }
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut config = SynthConfig {
        frames: 120,
        ..SynthConfig::default()
    };
    let (mut from, mut to, mut step, mut cell, mut status) = (0, usize::MAX, 1, 1, None);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| {
            v.parse::<usize>()
                .map_err(|_| format!("{flag}: '{v}' is not a count"))
        };
        match flag.as_str() {
            "--scene" => {
                config.scene = SceneKind::ALL
                    .into_iter()
                    .find(|k| k.name() == value)
                    .ok_or_else(|| format!("--scene: unknown scene '{value}'"))?;
            }
            "--traj" => {
                config.trajectory = TrajectoryKind::ALL
                    .into_iter()
                    .find(|k| k.name() == value)
                    .ok_or_else(|| format!("--traj: unknown trajectory '{value}'"))?;
            }
            "--seed" => config.seed = number(&value)? as u64,
            "--frames" => config.frames = number(&value)?,
            "--from" => from = number(&value)?,
            "--to" => to = number(&value)?,
            "--step" => step = number(&value)?.max(1),
            "--cell" => cell = number(&value)?.max(1),
            "--status" => status = Some(value),
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    Ok(Args {
        config,
        from,
        to,
        step,
        cell,
        status,
    })
}

fn run(args: &Args) -> Result<(), String> {
    let sequence = SynthSequence::new(args.config.clone());
    let statuses = match &args.status {
        Some(path) => read_statuses(path)?,
        None => HashMap::new(),
    };
    let noise = NoiseConfig::default();
    // Luma of three channels with independent noise, each rounded to 8 bits, the luma
    // rounded again.
    let quantisation = 1.0 / 12.0;
    let weights2: f64 = LUMA_WEIGHTS.iter().map(|w| w * w).sum();
    let luma_variance = (noise.image_sigma.powi(2) + quantisation) * weights2 + quantisation;
    println!(
        "frame  depth (mm)  + intensity, gain known (mm)  + intensity, gain free (mm)  status"
    );
    let mut bound = Bound::new(&args.config.camera, args.cell);
    let (mut frames, mut beyond) = (0, 0);
    for i in (args.from..args.to.min(sequence.len())).step_by(args.step) {
        let information = bound.frame(&sequence, i, luma_variance);
        let worst =
            |h: &Matrix6<f64>| analyse_constraint(h, LEVER_ARM_M, MAX_SIGMA_M).worst_sigma_m;
        let (depth, known, free) = (
            worst(&information.depth),
            worst(&(information.depth + information.intensity_known_gain)),
            worst(&(information.depth + information.intensity_free_gain)),
        );
        frames += 1;
        beyond += usize::from(free > MAX_SIGMA_M);
        let status = statuses.get(&i).map_or("", String::as_str);
        println!(
            "{i:5}  {:10.2}  {:28.2}  {:27.2}  {status}",
            1e3 * depth,
            1e3 * known,
            1e3 * free
        );
    }
    println!(
        "{beyond} of {frames} frames leave a direction above {} mm with every pixel's \
         intensity (gain free) and depth",
        1e3 * MAX_SIGMA_M
    );
    Ok(())
}

/// Frame index (0-based line of `status.txt`) to status.
fn read_statuses(path: &str) -> Result<HashMap<usize, String>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    Ok(text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .enumerate()
        .filter_map(|(i, l)| l.split_whitespace().nth(2).map(|s| (i, s.to_owned())))
        .collect())
}

/// The pose information of one frame, 6 x 6, pose as a left perturbation of
/// `camera_from_world` (translation first).
struct Information {
    depth: Matrix6<f64>,
    intensity_known_gain: Matrix6<f64>,
    intensity_free_gain: Matrix6<f64>,
}

/// Reused render and cell buffers.
struct Bound {
    camera: PinholeCamera,
    /// Pixels per intensity cell side.
    cell: usize,
    /// Per cell, the sum of its pixels' luma derivatives (pose, gain); `None` when one
    /// of its pixels is at an occlusion edge or has no depth.
    cells: Vec<Option<SVector<f64, 7>>>,
    luma: Vec<f32>,
    depth: Vec<f32>,
    /// Per pose direction, the renders at the two moved poses.
    moved: Vec<[(Vec<f32>, Vec<f32>); 2]>,
}

impl Bound {
    fn new(camera: &PinholeCamera, cell: usize) -> Self {
        Self {
            camera: *camera,
            cell,
            cells: Vec::new(),
            luma: Vec::new(),
            depth: Vec::new(),
            moved: (0..6).map(|_| Default::default()).collect(),
        }
    }

    fn frame(&mut self, sequence: &SynthSequence, i: usize, luma_variance: f64) -> Information {
        let scene = sequence.scene();
        let world_from_camera = sequence.pose(i);
        let gain = sequence.gain(i);
        render_luma_view(
            scene,
            &self.camera,
            &world_from_camera,
            &mut self.luma,
            &mut self.depth,
        );
        let camera_from_world = world_from_camera.inverse();
        let steps = [STEP_M, STEP_M, STEP_M, STEP_RAD, STEP_RAD, STEP_RAD];
        for (k, renders) in self.moved.iter_mut().enumerate() {
            for (sign, (luma, depth)) in [1.0, -1.0].into_iter().zip(renders.iter_mut()) {
                let delta = Vector6::ith(k, sign * steps[k]);
                let moved: Isometry3<f64> = se3::exp(&delta) * camera_from_world;
                render_luma_view(scene, &self.camera, &moved.inverse(), luma, depth);
            }
        }
        // Whole cells only; columns: the six pose directions, then the gain (d I / d gain
        // = I at gain 1).
        let (width, cell) = (self.camera.width, self.cell);
        let cells_wide = width / cell;
        let cells_high = self.luma.len() / width.max(1) / cell;
        self.cells.clear();
        self.cells
            .resize(cells_wide * cells_high, Some(SVector::zeros()));
        let mut depth_information = Matrix6::zeros();
        for p in 0..self.luma.len() {
            let (x, y) = (p % width, p / width);
            let in_cell = (x < cells_wide * cell && y < cells_high * cell)
                .then(|| (y / cell) * cells_wide + x / cell);
            let z = self.depth[p];
            let at_edge = z <= 0.0
                || self.moved.iter().any(|[(_, plus), (_, minus)]| {
                    plus[p] <= 0.0 || minus[p] <= 0.0 || (plus[p] - minus[p]).abs() > EDGE_JUMP_M
                });
            if at_edge {
                if let Some(c) = in_cell {
                    self.cells[c] = None;
                }
                continue;
            }
            let mut d_luma = SVector::<f64, 7>::zeros();
            let mut d_depth = Vector6::zeros();
            for (k, [(luma_plus, depth_plus), (luma_minus, depth_minus)]) in
                self.moved.iter().enumerate()
            {
                let two_steps = 2.0 * steps[k];
                d_luma[k] = gain * f64::from(luma_plus[p] - luma_minus[p]) / two_steps;
                d_depth[k] = f64::from(depth_plus[p] - depth_minus[p]) / two_steps;
            }
            d_luma[6] = gain * f64::from(self.luma[p]);
            if let Some(Some(sum)) = in_cell.map(|c| &mut self.cells[c]) {
                *sum += d_luma;
            }
            let sigma_z = DEPTH_SIGMA_PER_Z2 * f64::from(z).powi(2);
            depth_information += d_depth * d_depth.transpose() / (2.0 * sigma_z * sigma_z);
        }
        // A cell's mean has 1 / n of a pixel's variance, and both images carry the
        // noise: the difference has twice it.
        let n = (cell * cell) as f64;
        let mut intensity = SMatrix::<f64, 7, 7>::zeros();
        for mean in self.cells.iter().flatten().map(|sum| sum / n) {
            intensity += mean * mean.transpose() * n / (2.0 * luma_variance);
        }
        let known: Matrix6<f64> = intensity.fixed_view::<6, 6>(0, 0).into_owned();
        let cross: Vector6<f64> = intensity.fixed_view::<6, 1>(0, 6).into_owned();
        let gain_information = intensity[(6, 6)];
        let free = if gain_information > 0.0 {
            known - cross * cross.transpose() / gain_information
        } else {
            known
        };
        Information {
            depth: depth_information,
            intensity_known_gain: known,
            intensity_free_gain: free,
        }
    }
}
