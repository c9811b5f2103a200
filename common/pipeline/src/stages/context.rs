//! What every stage loop is given: its settings, its iceoryx2 node in the run, and the
//! stop request.

use crate::config::{Config, ConfigError};
use crate::map_files::MapFiles;
use crate::progress::ProgressBoard;
use crate::state::{StateDir, StateError};
use gfs_ipc::topics::TopicSpec;
use gfs_ipc::{
    IpcError, IpcRun, Mode, MsgHeader, Service, Stage, TopicPublisher, TopicSample,
    TopicSubscriber, ZeroCopySend,
};
use iceoryx2::node::{Node, NodeWaitFailure};
use std::fmt::Debug;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How long an idle stage sleeps between looks at its inputs when no wake-up comes.
pub const POLL: Duration = Duration::from_millis(2);

/// Sets `stage`'s received stamp to when its last input was published (`ready_ns`, or
/// the latest finished stamp in `header` when 0), so that the stage's queueing time is
/// how long a ready input waited for it.
pub fn mark_ready(header: &mut MsgHeader, stage: Stage, ready_ns: u64) {
    let latest = header
        .stamps
        .iter()
        .map(|s| s.finished_ns)
        .max()
        .unwrap_or(0);
    match ready_ns.max(latest) {
        0 => header.mark_received(stage),
        ns => header.stamp_mut(stage).received_ns = ns,
    }
}

/// A stage could not start or its transport failed.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// The config is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A topic or node failed.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A checkpoint could not be written or read.
    #[error(transparent)]
    State(#[from] StateError),
    /// The dataset cannot be opened.
    #[error("source: {0}")]
    Dataset(String),
    /// The map file cannot be read (or is not this camera's).
    #[error(transparent)]
    MapFile(#[from] gfs_odometry::map_file::MapFileError),
    /// A front-end extractor refused its config.
    #[error("{stage}: {message}")]
    Setup {
        /// The stage.
        stage: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Everything a stage is configured by (the same for every stage of a run).
#[derive(Clone, Debug)]
pub struct StageSettings {
    /// The config, with the ablation switches applied.
    pub config: Config,
    /// How the pipeline is paced.
    pub mode: Mode,
    /// Where stages keep their checkpoints (`None`: no restart recovery).
    pub state_dir: Option<PathBuf>,
    /// The dataset folder the source plays.
    pub dataset: PathBuf,
    /// The dataset's frame the source plays first, as the run's frame 0.
    pub start: usize,
    /// Play only N frames (from `start`).
    pub frames: Option<usize>,
    /// Realtime: play at this rate (frames per second) instead of the capture times.
    pub max_rate: Option<f64>,
    /// The map files: the mapper and the tracker start on a loaded map, the mapper
    /// saves the global map.
    pub map_files: MapFiles,
}

/// A stage's settings, node and stop request.
pub struct StageContext<S: Service> {
    /// The run (topic names, cleanup).
    pub run: IpcRun,
    /// The stage's node.
    pub node: Node<S>,
    /// The settings.
    pub settings: StageSettings,
    stop: Arc<AtomicBool>,
    stage: Stage,
    board: Option<ProgressBoard>,
}

impl<S: Service> StageContext<S> {
    /// A context for `stage` as a process: the node handles SIGINT / SIGTERM, which end
    /// the stage loop cleanly.
    ///
    /// # Errors
    /// [`IpcError`] when the node cannot be created.
    pub fn process(run: IpcRun, stage: Stage, settings: StageSettings) -> Result<Self, IpcError> {
        let node = run.stage_node(stage)?;
        let board = settings.state_dir.as_deref().and_then(ProgressBoard::open);
        Ok(Self {
            run,
            node,
            settings,
            stop: Arc::new(AtomicBool::new(false)),
            stage,
            board,
        })
    }

    /// A context for `stage` as a thread: it stops when `stop` is set.
    ///
    /// # Errors
    /// [`IpcError`] when the node cannot be created.
    pub fn thread(
        run: IpcRun,
        stage: Stage,
        settings: StageSettings,
        stop: Arc<AtomicBool>,
    ) -> Result<Self, IpcError> {
        let node = run.node(stage.name())?;
        let board = settings.state_dir.as_deref().and_then(ProgressBoard::open);
        Ok(Self {
            run,
            node,
            settings,
            stop,
            stage,
            board,
        })
    }

    /// True once the stage was asked to stop (signal or flag).
    pub fn stopping(&self) -> bool {
        if self.stop.load(Ordering::Relaxed) {
            return true;
        }
        if matches!(
            self.node.wait(Duration::ZERO),
            Err(NodeWaitFailure::TerminationRequest)
        ) {
            self.stop.store(true, Ordering::Relaxed);
            return true;
        }
        false
    }

    /// The next frame to work on: the oldest queued in lockstep, the newest in realtime
    /// (older ones are dropped). `None` after idling up to `idle` when none is queued;
    /// the idle `publisher` then lets restarted subscribers connect to its history.
    ///
    /// # Errors
    /// [`IpcError`] when the transport fails.
    pub fn next_frame<P: Debug + ZeroCopySend + 'static>(
        &self,
        frames: &TopicSubscriber<S, u8>,
        publisher: &TopicPublisher<S, P>,
        idle: Duration,
    ) -> Result<Option<TopicSample<S, u8>>, IpcError> {
        let sample = match self.mode() {
            Mode::Lockstep => frames.receive()?,
            Mode::Realtime => frames.receive_latest()?,
        };
        if sample.is_none() {
            publisher.update_connections()?;
            frames.wait(idle)?;
        }
        Ok(sample)
    }

    /// Notes on the progress board that the stage published frame `frame`.
    pub fn made(&self, frame: u64) {
        if let Some(board) = &self.board {
            board.made(self.stage, frame);
        }
    }

    /// Notes on the progress board that the tracker asked for keyframe `frame`.
    pub fn requested(&self, frame: u64) {
        if let Some(board) = &self.board {
            board.requested(frame);
        }
    }

    /// The run's checkpoint folder.
    pub fn state(&self) -> StateDir {
        StateDir::new(self.settings.state_dir.clone())
    }

    /// The config.
    pub fn config(&self) -> &Config {
        &self.settings.config
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        self.settings.mode
    }

    /// How long the tracker and the planes stage wait for a missing input.
    pub fn feature_deadline(&self) -> Duration {
        let p = &self.settings.config.pipeline;
        Duration::from_millis(match self.settings.mode {
            Mode::Lockstep => p.lockstep_feature_deadline_ms,
            Mode::Realtime => p.realtime_feature_deadline_ms,
        })
    }

    /// After how long an unanswered request is sent again.
    pub fn resend_after(&self) -> Duration {
        Duration::from_millis(self.settings.config.pipeline.resend_after_ms)
    }

    /// A subscriber to `topic`.
    ///
    /// # Errors
    /// [`IpcError`] when the topic cannot be opened.
    pub fn subscribe<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: TopicSpec,
    ) -> Result<TopicSubscriber<S, T>, IpcError> {
        TopicSubscriber::create(&self.run, &self.node, topic.name, &topic.qos(self.mode()))
    }

    /// A publisher of `topic` sized for slices of `initial_len`.
    ///
    /// # Errors
    /// [`IpcError`] when the topic cannot be opened.
    pub fn publish<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: TopicSpec,
        initial_len: usize,
    ) -> Result<TopicPublisher<S, T>, IpcError> {
        TopicPublisher::create(
            &self.run,
            &self.node,
            topic.name,
            &topic.qos(self.mode()),
            initial_len.max(1),
        )
    }

    /// The ORB pyramid (scale factor, levels) of the config.
    ///
    /// # Errors
    /// [`StageError::Setup`] when there are more than 255 levels.
    pub fn pyramid(&self) -> Result<(f64, u8), StageError> {
        let points = &self.settings.config.points;
        let levels = u8::try_from(points.levels).map_err(|_| StageError::Setup {
            stage: self.stage.name(),
            message: format!("points.levels = {} must be below 256", points.levels),
        })?;
        Ok((f64::from(points.scale_factor), levels))
    }
}
