//! `gfsvo vocab eval DATASET`: how well a vocabulary retrieves the keyframes that truly
//! overlap a frame. Every `--every`-th frame is a keyframe; every other frame with
//! ground truth is a query; a keyframe is relevant to a query when their ground-truth
//! poses are within `--max-distance` and `--max-angle`. Recall@n is the fraction of
//! queries (with at least one relevant keyframe) whose top n results hold a relevant
//! one. The "revisits" rows leave out the keyframes within `--gap` frames of the query,
//! the loop-closure case: only a place seen at another time counts.

use super::DescriptorSource;
use crate::CliResult;
use crate::config::Config;
use clap::Args;
use gfs_core::descriptor::Descriptor;
use gfs_dataset::Sequence;
use gfs_dataset::trajectory::{Trajectory, associate};
use gfs_place::{KeyFrameDatabase, Vocabulary, VocabularyConfig};
use nalgebra::Isometry3;
use std::path::PathBuf;
use std::time::Instant;

/// Largest gap between a frame's and its ground truth's timestamps, seconds.
const MAX_TIME_DIFFERENCE: f64 = 0.02;

/// Arguments of `gfsvo vocab eval`.
#[derive(Args)]
pub struct EvalArgs {
    /// Dataset folder in TUM layout with groundtruth.txt.
    dataset: PathBuf,
    /// Config TOML (default: chosen from the dataset folder name).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Vocabulary file [default: the shipped one, gfs_place::Vocabulary::default_orb].
    #[arg(long)]
    vocab: Option<PathBuf>,
    /// Also train a vocabulary of the same k and L on this dataset's own frames and
    /// evaluate it (an optimistic reference: it has seen the queries).
    #[arg(long)]
    train_here: bool,
    /// Every N-th frame is a keyframe.
    #[arg(long, default_value_t = 10)]
    every: usize,
    /// A relevant keyframe is within this distance of the query, metres.
    #[arg(long, default_value_t = 0.3)]
    max_distance: f64,
    /// ... and within this rotation angle, degrees.
    #[arg(long, default_value_t = 20.0)]
    max_angle: f64,
    /// The revisit rows ignore keyframes within this many frames of the query.
    #[arg(long, default_value_t = 30)]
    gap: usize,
}

/// A frame with ground truth and its descriptors.
struct EvalFrame {
    index: usize,
    pose: Isometry3<f64>,
    descriptors: Vec<Descriptor>,
}

/// Recall and timing of one vocabulary under one exclusion rule.
struct Row {
    queries: usize,
    skipped: usize,
    hits_at_1: usize,
    hits_at_3: usize,
    median_ms: f64,
}

/// Runs `gfsvo vocab eval`.
///
/// # Errors
/// Dataset, config, ground truth, vocabulary file and extraction errors.
pub fn run(args: &EvalArgs) -> CliResult {
    let shipped = match &args.vocab {
        Some(path) => (path.display().to_string(), Vocabulary::load(path)?),
        None => (
            "shipped (default_orb)".to_owned(),
            Vocabulary::default_orb(),
        ),
    };
    let frames = load_frames(&args.dataset, args.config.as_deref())?;
    let mut vocabularies = vec![shipped];
    if args.train_here {
        let images: Vec<Vec<Descriptor>> = frames.iter().map(|f| f.descriptors.clone()).collect();
        let config = VocabularyConfig {
            branching: vocabularies[0].1.branching(),
            levels: vocabularies[0].1.levels(),
            ..VocabularyConfig::default()
        };
        let start = Instant::now();
        let own = Vocabulary::train(&images, &config, "trained on the evaluated frames")?;
        println!(
            "trained on the dataset's {} frames in {:.1} s",
            frames.len(),
            start.elapsed().as_secs_f64()
        );
        vocabularies.push(("trained on this dataset".to_owned(), own));
    }
    println!(
        "{}: {} frames with ground truth, keyframe every {}, relevant within {} m and {} deg",
        args.dataset.display(),
        frames.len(),
        args.every,
        args.max_distance,
        args.max_angle
    );
    println!(
        "{:<44} {:>6} {:>8} {:>8} {:>9} {:>9} {:>9}",
        "vocabulary", "words", "queries", "no-match", "recall@1", "recall@3", "median ms"
    );
    for (name, vocabulary) in &vocabularies {
        for (label, gap) in [("all keyframes", 0), ("revisits", args.gap)] {
            let row = evaluate(vocabulary, &frames, args, gap);
            let rate = |n: usize| n as f64 / row.queries.max(1) as f64;
            println!(
                "{:<44} {:>6} {:>8} {:>8} {:>9.3} {:>9.3} {:>9.2}",
                format!("{name}, {label}"),
                vocabulary.num_words(),
                row.queries,
                row.skipped,
                rate(row.hits_at_1),
                rate(row.hits_at_3),
                row.median_ms
            );
        }
    }
    Ok(())
}

/// Every frame of the dataset that has ground truth, with its ORB descriptors.
fn load_frames(
    dir: &std::path::Path,
    config: Option<&std::path::Path>,
) -> CliResult<Vec<EvalFrame>> {
    let config = Config::load(config, dir)?;
    let sequence = Sequence::open(dir, &config.camera()?, &config.depth)?;
    let gt_path = sequence
        .ground_truth_path()
        .ok_or_else(|| format!("{} has no groundtruth.txt", dir.display()))?;
    let truth = Trajectory::read_tum(&gt_path)?;
    let mut stamps = Trajectory::new();
    for &t in sequence.timestamps() {
        stamps.push(t, Isometry3::identity());
    }
    let mut pose_of_frame = vec![None; sequence.len()];
    for (frame, gt) in associate(&stamps, &truth, MAX_TIME_DIFFERENCE) {
        pose_of_frame[frame] = Some(truth.poses()[gt]);
    }
    let mut source = DescriptorSource::new(config.points.clone())?;
    let mut frames = Vec::new();
    for (index, frame) in sequence.frames(None).enumerate() {
        let frame = frame?;
        if let Some(pose) = pose_of_frame.get(index).copied().flatten() {
            frames.push(EvalFrame {
                index,
                pose,
                descriptors: source.extract(&frame.gray, &frame.depth)?,
            });
        }
    }
    Ok(frames)
}

/// Retrieval of every query against the keyframes more than `gap` frames away.
fn evaluate(vocabulary: &Vocabulary, frames: &[EvalFrame], args: &EvalArgs, gap: usize) -> Row {
    let every = args.every.max(1);
    let max_angle = args.max_angle.to_radians();
    let mut database = KeyFrameDatabase::new(vocabulary.num_words());
    let keyframes: Vec<&EvalFrame> = frames.iter().filter(|f| f.index % every == 0).collect();
    for kf in &keyframes {
        database.add(kf.index, &vocabulary.transform(&kf.descriptors));
    }
    let overlaps = |a: &Isometry3<f64>, b: &Isometry3<f64>| {
        let rel = a.inverse() * b;
        rel.translation.vector.norm() <= args.max_distance && rel.rotation.angle() <= max_angle
    };
    let mut row = Row {
        queries: 0,
        skipped: 0,
        hits_at_1: 0,
        hits_at_3: 0,
        median_ms: 0.0,
    };
    let mut times = Vec::new();
    for query in frames.iter().filter(|f| f.index % every != 0) {
        let far = |index: usize| index.abs_diff(query.index) > gap;
        let relevant: Vec<usize> = keyframes
            .iter()
            .filter(|kf| far(kf.index) && overlaps(&kf.pose, &query.pose))
            .map(|kf| kf.index)
            .collect();
        if relevant.is_empty() {
            row.skipped += 1;
            continue;
        }
        let start = Instant::now();
        let bow = vocabulary.transform(&query.descriptors);
        let results = database.query(&bow, 3, |index| !far(index));
        times.push(start.elapsed().as_secs_f64() * 1e3);
        row.queries += 1;
        let hit = |n: usize| results.iter().take(n).any(|(id, _)| relevant.contains(id));
        row.hits_at_1 += usize::from(hit(1));
        row.hits_at_3 += usize::from(hit(3));
    }
    times.sort_by(f64::total_cmp);
    row.median_ms = times.get(times.len() / 2).copied().unwrap_or(0.0);
    row
}
