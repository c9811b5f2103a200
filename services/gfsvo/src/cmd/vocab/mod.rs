//! `gfsvo vocab build` / `gfsvo vocab eval`: train the place-recognition vocabulary
//! (`gfs_place::Vocabulary`) from images the project renders or reads, and measure
//! keyframe retrieval with it on a dataset with ground truth.

mod build;
mod eval;

use crate::CliResult;
use clap::Subcommand;
use gfs_core::descriptor::Descriptor;
use gfs_core::{DepthImage, GrayImage};
use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures};

/// The vocabulary subcommands.
#[derive(Subcommand)]
pub enum VocabCommand {
    /// Train a vocabulary on ORB descriptors of rendered synthetic scenes and / or
    /// dataset folders, and write it (versioned, checksummed binary).
    Build(build::BuildArgs),
    /// Keyframe retrieval on a dataset with ground truth: recall@1 / @3 of keyframes
    /// that truly overlap each held-out frame, and the query time.
    Eval(eval::EvalArgs),
}

/// Runs one vocabulary subcommand.
///
/// # Errors
/// Those of the subcommand.
pub fn run(command: &VocabCommand) -> CliResult {
    match command {
        VocabCommand::Build(args) => build::run(args),
        VocabCommand::Eval(args) => eval::run(args),
    }
}

/// ORB descriptors of frames, with the project's extractor and one reused buffer.
struct DescriptorSource {
    extractor: OrbExtractor,
    features: OrbFeatures,
}

impl DescriptorSource {
    fn new(config: OrbConfig) -> CliResult<Self> {
        Ok(Self {
            extractor: OrbExtractor::new(config)?,
            features: OrbFeatures::default(),
        })
    }

    /// The descriptors of one frame (depth only checks the size; retrieval ignores it).
    fn extract(&mut self, gray: &GrayImage, depth: &DepthImage) -> CliResult<Vec<Descriptor>> {
        self.extractor
            .extract(gray.view(), Some(depth.view()), &mut self.features)?;
        Ok(self.features.descriptors.clone())
    }
}
