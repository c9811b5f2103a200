//! `gfsvo vocab build`: renders synthetic scenes (and / or reads dataset folders),
//! extracts ORB descriptors with the project's front end and trains the vocabulary.

use super::DescriptorSource;
use crate::CliResult;
use crate::config::Config;
use clap::Args;
use gfs_core::descriptor::Descriptor;
use gfs_dataset::Sequence;
use gfs_place::{Vocabulary, VocabularyConfig};
use gfs_points::OrbConfig;
use gfs_synth::{SceneKind, SynthConfig, SynthSequence, TrajectoryKind};
use std::path::PathBuf;
use std::time::Instant;

/// Frames of each rendered trajectory (10 s at 30 Hz) from which the training frames
/// are picked evenly.
const TRAJECTORY_FRAMES: usize = 300;

/// Arguments of `gfsvo vocab build`.
#[derive(Args)]
#[command(after_help = "\
Synthetic sequence n (0-based) renders scene n % 3 (room, low-texture, corridor) along \
trajectory (n / 3) % 3 (slow, fast, rotation) with texture / trajectory seed \
--synth-seed + n, and contributes --frames frames picked evenly from its 300. Dataset \
folders contribute every --every-th frame. The vocabulary stores a description of how \
it was made (this command line and the counts).\n\n\
Example (the shipped vocabulary, see common/place/vocabulary/README.md):\n  \
gfsvo vocab build --out common/place/vocabulary/orb.bin --synth 36 --frames 20")]
pub struct BuildArgs {
    /// Output file.
    #[arg(long)]
    out: PathBuf,
    /// Dataset folders (TUM layout) to train on.
    #[arg(long, num_args = 1..)]
    images: Vec<PathBuf>,
    /// Config TOML of the dataset folders (default: chosen from each folder's name).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Use every N-th frame of the dataset folders.
    #[arg(long, default_value_t = 5)]
    every: usize,
    /// Number of synthetic sequences to render (0 = none).
    #[arg(long, default_value_t = 36)]
    synth: usize,
    /// Frames used per synthetic sequence.
    #[arg(long, default_value_t = 20)]
    frames: usize,
    /// Seed of the first synthetic sequence.
    #[arg(long, default_value_t = 100)]
    synth_seed: u64,
    /// Branching factor of the tree.
    #[arg(long, default_value_t = VocabularyConfig::default().branching)]
    k: usize,
    /// Depth of the tree.
    #[arg(long, default_value_t = VocabularyConfig::default().levels)]
    levels: usize,
    /// Seed of the clustering.
    #[arg(long, default_value_t = VocabularyConfig::default().seed)]
    seed: u64,
}

/// Runs `gfsvo vocab build`.
///
/// # Errors
/// Dataset, config, extraction, training and write errors.
pub fn run(args: &BuildArgs) -> CliResult {
    let start = Instant::now();
    let mut images = synthetic_images(args)?;
    let synthetic = images.len();
    for dir in &args.images {
        images.extend(dataset_images(
            dir,
            args.config.as_deref(),
            args.every.max(1),
        )?);
    }
    let descriptors: usize = images.iter().map(Vec::len).sum();
    println!(
        "{} images ({synthetic} rendered), {descriptors} descriptors in {:.1} s",
        images.len(),
        start.elapsed().as_secs_f64()
    );
    let config = VocabularyConfig {
        branching: args.k,
        levels: args.levels,
        seed: args.seed,
    };
    let command: Vec<String> = std::env::args().skip(1).collect();
    let description = format!(
        "gfsvo {}: {} images ({synthetic} rendered by gfs-synth, {} from datasets), \
         {descriptors} ORB descriptors (gfs-points, default config), k = {}, L = {}, seed {}",
        command.join(" "),
        images.len(),
        images.len() - synthetic,
        args.k,
        args.levels,
        args.seed
    );
    let trained = Instant::now();
    let vocabulary = Vocabulary::train(&images, &config, &description)?;
    vocabulary.save(&args.out)?;
    println!(
        "{} words, {} nodes, trained in {:.1} s; wrote {} ({} bytes)",
        vocabulary.num_words(),
        vocabulary.num_nodes(),
        trained.elapsed().as_secs_f64(),
        args.out.display(),
        vocabulary.to_bytes().len()
    );
    Ok(())
}

/// Descriptors of the rendered training frames, one list per frame.
fn synthetic_images(args: &BuildArgs) -> CliResult<Vec<Vec<Descriptor>>> {
    let mut source = DescriptorSource::new(OrbConfig::default())?;
    let mut images = Vec::new();
    let frames = args.frames.clamp(1, TRAJECTORY_FRAMES);
    for n in 0..args.synth {
        let sequence = SynthSequence::new(SynthConfig {
            scene: SceneKind::ALL[n % 3],
            trajectory: TrajectoryKind::ALL[(n / 3) % 3],
            frames: TRAJECTORY_FRAMES,
            seed: args.synth_seed + n as u64,
            ..SynthConfig::default()
        });
        for f in 0..frames {
            let frame = sequence.render(f * TRAJECTORY_FRAMES / frames);
            images.push(source.extract(&frame.gray, &frame.depth)?);
        }
    }
    Ok(images)
}

/// Descriptors of every `every`-th frame of a dataset folder.
fn dataset_images(
    dir: &std::path::Path,
    config: Option<&std::path::Path>,
    every: usize,
) -> CliResult<Vec<Vec<Descriptor>>> {
    let config = Config::load(config, dir)?;
    let sequence = Sequence::open(dir, &config.camera()?, &config.depth)?;
    let mut source = DescriptorSource::new(config.points.clone())?;
    let mut images = Vec::new();
    for (i, frame) in sequence.frames(None).enumerate() {
        let frame = frame?;
        if i % every == 0 {
            images.push(source.extract(&frame.gray, &frame.depth)?);
        }
    }
    Ok(images)
}
