//! The supervisor of `gfsvo run`: starts the stages (the loop stage with loop closing on) (as processes, or as threads in
//! `--mode threads`), records the pose of every frame, restarts a stage that dies, and
//! shuts everything down, leaving nothing of the run in shared memory.

mod children;
mod recorder;
mod restarts;
pub mod signals;
mod threads;
mod watchdog;

pub use recorder::{
    Anchors, Corrections, Covariances, FrameViews, Recorder, Scenes, complete_trajectory,
    final_poses,
};

use crate::CliResult;
use children::StageProcesses;
use gfs_ipc::profile::Profile;
use gfs_ipc::{IpcRun, RunId, Service, Stage, ipc, local};
use gfs_odometry::FramePose;
use gfs_odometry::map::Map;
use gfs_pipeline::progress::ProgressBoard;
use gfs_pipeline::stages::{StageSettings, last_saved_map, stages_to_run};
use gfs_pipeline::state::StateDir;
use restarts::RestartPolicy;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use threads::StageThreads;
use watchdog::Watchdog;

/// With no new pose for this long, the run is declared stalled.
const STALL: Duration = Duration::from_secs(60);
/// How long stopped stages get to exit before they are killed.
const STOP_GRACE: Duration = Duration::from_secs(3);

/// How to run the pipeline.
pub struct PipelineOptions {
    /// The settings every stage gets.
    pub settings: StageSettings,
    /// The config file given on the command line, passed on to the stage processes.
    pub config_path: Option<PathBuf>,
    /// Ablation switches, passed on to the stage processes.
    pub no_lines: bool,
    /// See `no_lines`.
    pub no_manhattan: bool,
    /// See `no_lines`.
    pub no_loop_closing: bool,
    /// The run id (iceoryx2 prefix).
    pub run_id: RunId,
    /// Log filter of the stage processes.
    pub log: String,
    /// Stages as threads of this process instead of processes.
    pub threads: bool,
    /// Number of input frames.
    pub total: usize,
    /// Output folder (for `pids.json`).
    pub out: PathBuf,
    /// No progress bar.
    pub quiet: bool,
    /// The executable that plays the source role instead of `gfsvo-source` (`gfsvo ros2`
    /// runs `gfsvo-ros2`).
    pub source_executable: Option<String>,
    /// Frames come until SIGINT / SIGTERM (a live camera): no last frame, no stall
    /// limit, and the interruption is the normal end.
    pub open_ended: bool,
    /// Keep the tracker's map after each keyframe as a scene (the `--mcap` recording's
    /// visualisation topics).
    pub keep_scenes: bool,
}

/// What a pipeline run produced.
pub struct PipelineOutcome {
    /// The poses received, by frame id.
    pub received: BTreeMap<u64, FramePose>,
    /// Their covariances (tracked frames), by frame id.
    pub covariances: Covariances,
    /// The tracker's loop corrections (`map_from_odom`) by frame id, once a loop closed.
    pub corrections: Corrections,
    /// Each frame's reference keyframe when it was tracked, by frame id.
    pub anchors: Anchors,
    /// The mapper's last saved map (`None` without a state folder or a keyframe).
    pub final_map: Option<Map>,
    /// The tracker's map after each keyframe (empty unless `keep_scenes`).
    pub scenes: Scenes,
    /// Each frame's matched keypoints and lines (empty unless `keep_scenes`).
    pub views: FrameViews,
    /// Stage stamps of every frame.
    pub profile: Profile,
    /// Keyframes made.
    pub keyframes: usize,
    /// The IMU samples the tracker took in.
    pub imu_samples: u64,
    /// Restarts per stage.
    pub restarts: BTreeMap<&'static str, u32>,
    /// True when SIGINT / SIGTERM ended the run early.
    pub interrupted: bool,
    /// Files of the run left in /dev/shm or /tmp/iceoryx2 afterwards (should be none).
    pub leftovers: Vec<PathBuf>,
}

/// Runs the pipeline over the dataset until every frame has a pose.
///
/// # Errors
/// When a stage cannot be started or keeps dying, the run stalls, or the transport
/// fails; every stage is stopped and the run's shared memory removed first.
pub fn run(options: &PipelineOptions) -> CliResult<PipelineOutcome> {
    signals::install();
    let swept = gfs_ipc::sweep_dead_runs();
    for (id, files) in &swept.removed {
        tracing::info!("removed {files} files left by dead run {id}");
    }
    let run = IpcRun::new(options.run_id.clone())?;
    let claim = run.claim()?;
    let policy = RestartPolicy::new(
        options.settings.config.pipeline.max_restarts,
        Duration::from_secs(options.settings.config.pipeline.restart_window_s),
    );
    let label = if options.threads {
        "threads"
    } else {
        mode_name(options)
    };
    if options.threads {
        let node = run.node::<local::Service>("recorder")?;
        let recorder = open_recorder(&run, &node, options, label)?;
        let mut pool =
            StageThreads::start(options.run_id.clone(), options.settings.clone(), policy)?;
        let result = supervise(&run, recorder, options, |_| pool.restart_dead());
        pool.stop();
        drop(node);
        let totals = Stage::ALL.map(|s| (s.name(), pool.restarts().total(s)));
        finish(options, run.finish(), result, totals)
    } else {
        let node = run.node::<ipc::Service>("recorder")?;
        let recorder = open_recorder(&run, &node, options, label)?;
        let dir = std::env::current_exe()?
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let mut watchdog = options.settings.state_dir.as_deref().and_then(|dir| {
            let timeout = options.settings.config.pipeline.hang_timeout_ms;
            ProgressBoard::create(dir)
                .map(|board| {
                    let timeout = Duration::from_millis(timeout);
                    let total = (!options.open_ended).then_some(options.total);
                    Watchdog::new(board, timeout, total, options.settings.mode)
                })
                .map_err(|e| tracing::warn!("no hung-stage detection: {e}"))
                .ok()
        });
        let mut pool = StageProcesses::start(
            &dir,
            &stages_to_run(&options.settings.config),
            stage_args(options),
            policy,
            options.settings.config.pipeline.scheduling.clone(),
            options.source_executable.clone(),
        )?;
        write_pids(&options.out, &pool.pids());
        let result = supervise(&run, recorder, options, |run| {
            for (stage, idle) in watchdog.as_mut().map(Watchdog::overdue).unwrap_or_default() {
                tracing::warn!(
                    stage = stage.name(),
                    "stage published nothing for {:.1} s while its input waited; killing it as hung",
                    idle.as_secs_f64()
                );
                pool.kill(stage);
            }
            let restarted = pool.restart_dead(run)?;
            if !restarted.is_empty() {
                write_pids(&options.out, &pool.pids());
                write_restarts(options, pool.restarts());
            }
            Ok(restarted)
        });
        pool.stop(STOP_GRACE);
        drop(node);
        let leftovers = claim.clean_up().unwrap_or_else(|e| {
            tracing::warn!("cleaning up the run: {e}");
            run.leftovers()
        });
        let totals = Stage::ALL.map(|s| (s.name(), pool.restarts().total(s)));
        finish(options, leftovers, result, totals)
    }
}

/// What the recorder collected over a supervised run.
struct Recorded {
    profile: Profile,
    received: BTreeMap<u64, FramePose>,
    covariances: Covariances,
    corrections: Corrections,
    anchors: Anchors,
    keyframes: usize,
    imu_samples: u64,
    scenes: Scenes,
    views: FrameViews,
    interrupted: bool,
}

type Supervised = CliResult<Recorded>;

/// Records poses until the last frame has one (or a signal came), restarting dead
/// stages on the way.
/// The supervisor's recorder of the run's poses (and, when asked, its scenes).
fn open_recorder<S: Service>(
    run: &IpcRun,
    node: &iceoryx2::node::Node<S>,
    options: &PipelineOptions,
    label: &str,
) -> Result<Recorder<S>, gfs_ipc::IpcError> {
    let mode = options.settings.mode;
    Recorder::new(run, node, mode, label)?.keeping_scenes(options.keep_scenes, run, node, mode)
}

fn supervise<S: Service>(
    run: &IpcRun,
    mut recorder: Recorder<S>,
    options: &PipelineOptions,
    mut restart_dead: impl FnMut(&IpcRun) -> Result<Vec<Stage>, children::ChildError>,
) -> Supervised {
    let last = options.total.saturating_sub(1) as u64;
    let mut progress = Instant::now();
    let bar = crate::cmd::run::progress_bar(options.total as u64, options.quiet);
    let mut interrupted = false;
    while options.total > 0 && (options.open_ended || !recorder.has(last)) {
        if recorder.drain()? > 0 {
            progress = Instant::now();
            bar.set_position(recorder.len() as u64);
        }
        if signals::interrupted() {
            tracing::warn!("interrupted: stopping the stages");
            interrupted = true;
            break;
        }
        restart_dead(run)?;
        if !options.open_ended && progress.elapsed() > STALL {
            return Err(format!(
                "the pipeline stalled: no pose for {} s after {} frames",
                STALL.as_secs(),
                recorder.len()
            )
            .into());
        }
        recorder.wait(Duration::from_millis(20))?;
    }
    recorder.drain()?;
    // The matches of a frame follow its pose: give the last frame's a moment.
    let deadline = Instant::now() + Duration::from_millis(500);
    while !interrupted && !recorder.has_view(last) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        recorder.drain()?;
    }
    bar.finish_and_clear();
    let keyframes = recorder.keyframes();
    let imu_samples = recorder.imu_samples();
    let corrections = recorder.take_corrections();
    let anchors = recorder.take_anchors();
    let scenes = recorder.take_scenes();
    let views = recorder.take_views();
    let (profile, received, covariances) = recorder.into_profile();
    Ok(Recorded {
        profile,
        received,
        covariances,
        corrections,
        anchors,
        keyframes,
        imu_samples,
        scenes,
        views,
        interrupted,
    })
}

fn finish(
    options: &PipelineOptions,
    leftovers: Vec<PathBuf>,
    result: Supervised,
    totals: [(&'static str, u32); Stage::COUNT],
) -> CliResult<PipelineOutcome> {
    if !leftovers.is_empty() {
        tracing::warn!("files of the run left behind: {leftovers:?}");
    }
    let recorded = result?;
    let final_map = last_saved_map(&StateDir::new(options.settings.state_dir.clone()))
        .unwrap_or_else(|e| {
            tracing::warn!("the final trajectory has no later loop corrections: {e}");
            None
        });
    Ok(PipelineOutcome {
        received: recorded.received,
        covariances: recorded.covariances,
        corrections: recorded.corrections,
        anchors: recorded.anchors,
        final_map,
        scenes: recorded.scenes,
        views: recorded.views,
        profile: recorded.profile,
        keyframes: recorded.keyframes,
        imu_samples: recorded.imu_samples,
        restarts: totals.into_iter().collect(),
        interrupted: recorded.interrupted,
        leftovers,
    })
}

fn mode_name(options: &PipelineOptions) -> &'static str {
    match options.settings.mode {
        gfs_ipc::Mode::Lockstep => "lockstep",
        gfs_ipc::Mode::Realtime => "realtime",
    }
}

/// The command line of every stage process. Every value is joined to its flag
/// (`--dataset=-x`), so that a path or id starting with `-` is not taken for a flag.
fn stage_args(options: &PipelineOptions) -> Vec<OsString> {
    let s = &options.settings;
    let flag = |name: &str, value: &std::ffi::OsStr| {
        let mut arg = OsString::from(format!("--{name}="));
        arg.push(value);
        arg
    };
    let mut args: Vec<OsString> = vec![
        flag("dataset", s.dataset.as_os_str()),
        flag("run-id", options.run_id.as_str().as_ref()),
        flag("mode", mode_name(options).as_ref()),
        flag("log", options.log.as_ref()),
    ];
    if let Some(path) = &options.config_path {
        args.push(flag("config", path.as_os_str()));
    }
    if let Some(dir) = &s.state_dir {
        args.push(flag("state-dir", dir.as_os_str()));
    }
    if s.start > 0 {
        args.push(flag("start", s.start.to_string().as_ref()));
    }
    if let Some(n) = s.frames {
        args.push(flag("frames", n.to_string().as_ref()));
    }
    if let Some(rate) = s.max_rate {
        args.push(flag("max-rate", rate.to_string().as_ref()));
    }
    if options.no_lines {
        args.push("--no-lines".into());
    }
    if options.no_manhattan {
        args.push("--no-manhattan".into());
    }
    if options.no_loop_closing {
        args.push("--no-loop-closing".into());
    }
    args.extend(s.map_files.stage_args());
    args
}

/// `pids.json`: the process id of each stage, rewritten at every restart (for
/// operators and the fault-injection tests).
fn write_pids(out: &Path, pids: &[(Stage, u32)]) {
    let map: BTreeMap<&str, u32> = pids.iter().map(|(s, p)| (s.name(), *p)).collect();
    let tmp = out.join(".pids.json.tmp");
    let text = serde_json::to_string(&map).unwrap_or_default();
    if let Err(e) =
        std::fs::write(&tmp, text).and_then(|()| std::fs::rename(&tmp, out.join("pids.json")))
    {
        tracing::warn!("cannot write pids.json: {e}");
    }
}

/// The restarts of every stage into the state folder (`/diagnostics` reports them).
fn write_restarts(options: &PipelineOptions, policy: &RestartPolicy) {
    let totals: Vec<(String, u32)> = Stage::ALL
        .iter()
        .map(|s| (s.name().to_owned(), policy.total(*s)))
        .collect();
    let state = gfs_pipeline::state::StateDir::new(options.settings.state_dir.clone());
    if let Err(e) = state.write(gfs_pipeline::state::RESTARTS, &totals, &mut Vec::new()) {
        tracing::warn!("{e}");
    }
}
