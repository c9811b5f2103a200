//! The stage processes of a run: started from the `gfsvo-<stage>` executables beside
//! `gfsvo`, killed with the supervisor (parent-death signal), restarted when they die.

use super::restarts::RestartPolicy;
use gfs_ipc::{IpcRun, Stage, ipc};
use gfs_pipeline::scheduling::SchedulingConfig;
use std::ffi::OsString;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A supervised stage could not be started or kept alive.
#[derive(Debug, thiserror::Error)]
pub enum ChildError {
    /// The stage executable is missing.
    #[error(
        "stage executable {0} not found: build every binary of the workspace \
         (`cargo build --release`) or install the gfsvo-* executables beside gfsvo"
    )]
    Missing(PathBuf),
    /// The OS refused to start it.
    #[error("cannot start {path}: {source}")]
    Spawn {
        /// The executable.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// It died too often.
    #[error("stage {stage} died {count} times within {window_s} s (last: {last}); giving up")]
    GaveUp {
        /// The stage.
        stage: &'static str,
        /// Deaths within the window.
        count: usize,
        /// The window, seconds.
        window_s: u64,
        /// How it died the last time.
        last: String,
    },
}

/// The running stage processes.
pub struct StageProcesses {
    dir: PathBuf,
    source_executable: Option<String>,
    args: Vec<OsString>,
    children: Vec<(Stage, Child)>,
    policy: RestartPolicy,
    scheduling: SchedulingConfig,
}

impl StageProcesses {
    /// Starts `stages` with `args` (the same for all), scheduled as `scheduling`
    /// says; the source role is played by `source_executable` when given (`gfsvo-ros2`).
    ///
    /// # Errors
    /// [`ChildError`] when an executable is missing or cannot start.
    pub fn start(
        dir: &Path,
        stages: &[Stage],
        args: Vec<OsString>,
        policy: RestartPolicy,
        scheduling: SchedulingConfig,
        source_executable: Option<String>,
    ) -> Result<Self, ChildError> {
        for &stage in stages {
            let path = executable(dir, stage, source_executable.as_deref());
            if !path.is_file() {
                return Err(ChildError::Missing(path));
            }
        }
        let mut pool = Self {
            dir: dir.to_path_buf(),
            source_executable,
            args,
            children: Vec::new(),
            policy,
            scheduling,
        };
        for &stage in stages {
            let child = pool.spawn(stage)?;
            pool.children.push((stage, child));
        }
        Ok(pool)
    }

    /// Process id of each stage.
    pub fn pids(&self) -> Vec<(Stage, u32)> {
        self.children.iter().map(|(s, c)| (*s, c.id())).collect()
    }

    /// Restarts every stage that died since the last call, after cleaning up what its
    /// dead node left in shared memory. Returns the stages restarted.
    ///
    /// # Errors
    /// [`ChildError::GaveUp`] when a stage keeps dying; [`ChildError::Spawn`].
    pub fn restart_dead(&mut self, run: &IpcRun) -> Result<Vec<Stage>, ChildError> {
        let mut dead = Vec::new();
        for (stage, child) in &mut self.children {
            if let Ok(Some(status)) = child.try_wait() {
                dead.push((*stage, status.to_string()));
            }
        }
        if dead.is_empty() {
            return Ok(dead.into_iter().map(|(s, _)| s).collect());
        }
        if let Err(e) = run.cleanup_dead_nodes::<ipc::Service>() {
            tracing::warn!("cleaning up after a dead stage: {e}");
        }
        for (stage, how) in &dead {
            tracing::warn!(stage = stage.name(), "stage died ({how}); restarting it");
            self.policy.record(*stage, how)?;
            let child = self.spawn(*stage)?;
            if let Some(slot) = self.children.iter_mut().find(|(s, _)| s == stage) {
                slot.1 = child;
            }
        }
        Ok(dead.into_iter().map(|(s, _)| s).collect())
    }

    /// Kills `stage` (SIGKILL: it also ends a stopped process); the next
    /// [`Self::restart_dead`] restarts it.
    pub fn kill(&mut self, stage: Stage) {
        if let Some((_, child)) = self.children.iter_mut().find(|(s, _)| *s == stage) {
            let _ = child.kill();
        }
    }

    /// Restarts per stage so far.
    pub fn restarts(&self) -> &RestartPolicy {
        &self.policy
    }

    /// Asks every stage to stop (SIGTERM), waits up to `grace` for them to exit, then
    /// kills the rest.
    pub fn stop(&mut self, grace: Duration) {
        for (_, child) in &self.children {
            if let Ok(pid) = i32::try_from(child.id()) {
                // SAFETY: kill(2) on our own child's pid has no memory effects.
                unsafe {
                    libc::kill(pid, libc::SIGTERM);
                }
            }
        }
        let deadline = Instant::now() + grace;
        for (stage, child) in &mut self.children {
            while Instant::now() < deadline {
                if matches!(child.try_wait(), Ok(Some(_))) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            if !matches!(child.try_wait(), Ok(Some(_))) {
                tracing::warn!(
                    stage = stage.name(),
                    "stage did not stop in time; killing it"
                );
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }

    fn spawn(&self, stage: Stage) -> Result<Child, ChildError> {
        let path = executable(&self.dir, stage, self.source_executable.as_deref());
        let mut command = Command::new(&path);
        command.args(&self.args).stdin(Stdio::null());
        let scheduling = self.scheduling.for_stage(stage);
        let prepared = scheduling.prepare();
        // SAFETY: the closure only makes system calls (prctl, getppid, raise and the
        // scheduling calls), which are async-signal-safe, between fork and exec.
        unsafe {
            command.pre_exec(move || {
                // Die with the supervisor, even if it is SIGKILLed.
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
                if libc::getppid() == 1 {
                    libc::raise(libc::SIGKILL);
                }
                prepared.apply_to_this_process();
                Ok(())
            });
        }
        let child = command
            .spawn()
            .map_err(|source| ChildError::Spawn { path, source })?;
        if let Ok(pid) = i32::try_from(child.id()) {
            for refused in scheduling.differences(pid) {
                tracing::warn!(stage = stage.name(), "[pipeline.scheduling] {refused}");
            }
        }
        Ok(child)
    }
}

impl Drop for StageProcesses {
    fn drop(&mut self) {
        for (_, child) in &mut self.children {
            if matches!(child.try_wait(), Ok(None)) {
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }
}

fn executable(dir: &Path, stage: Stage, source: Option<&str>) -> PathBuf {
    match (stage, source) {
        (Stage::Source, Some(name)) => dir.join(name),
        _ => dir.join(format!("gfsvo-{}", stage.name())),
    }
}
