//! `--mode threads`: every stage as a thread of this process over iceoryx2 `local`
//! services, the same stage code as the processes run.

use super::children::ChildError;
use super::restarts::RestartPolicy;
use gfs_ipc::{IpcRun, RunId, Stage, local};
use gfs_pipeline::stages::stages_to_run;
use gfs_pipeline::stages::{StageContext, StageSettings, run_stage};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

/// A stage thread: its result is the reason it ended, if it failed.
type StageThread = JoinHandle<Result<(), String>>;

/// The running stage threads.
pub struct StageThreads {
    run_id: RunId,
    settings: StageSettings,
    stop: Arc<AtomicBool>,
    threads: Vec<(Stage, Option<StageThread>)>,
    policy: RestartPolicy,
}

impl StageThreads {
    /// Starts every stage as a thread.
    ///
    /// # Errors
    /// [`ChildError::Spawn`] when the OS refuses a thread.
    pub fn start(
        run_id: RunId,
        settings: StageSettings,
        policy: RestartPolicy,
    ) -> Result<Self, ChildError> {
        let mut pool = Self {
            run_id,
            settings,
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::new(),
            policy,
        };
        for stage in stages_to_run(&pool.settings.config) {
            let handle = pool.spawn(stage)?;
            pool.threads.push((stage, Some(handle)));
        }
        Ok(pool)
    }

    /// Restarts every stage thread that ended (an error) since the last call.
    ///
    /// # Errors
    /// [`ChildError::GaveUp`] when a stage keeps failing; [`ChildError::Spawn`].
    pub fn restart_dead(&mut self) -> Result<Vec<Stage>, ChildError> {
        let mut restarted = Vec::new();
        for i in 0..self.threads.len() {
            let stage = self.threads[i].0;
            if !self.threads[i].1.as_ref().is_some_and(|h| h.is_finished()) {
                continue;
            }
            let how = match self.threads[i].1.take().map(JoinHandle::join) {
                Some(Ok(Ok(()))) => "ended".to_owned(),
                Some(Ok(Err(e))) => e,
                _ => "panicked".to_owned(),
            };
            tracing::warn!(
                stage = stage.name(),
                "stage thread ended ({how}); restarting it"
            );
            self.policy.record(stage, &how)?;
            self.threads[i].1 = Some(self.spawn(stage)?);
            restarted.push(stage);
        }
        Ok(restarted)
    }

    /// Restarts per stage so far.
    pub fn restarts(&self) -> &RestartPolicy {
        &self.policy
    }

    /// Stops every stage and waits for it.
    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for (stage, handle) in &mut self.threads {
            if let Some(Ok(Err(e))) = handle.take().map(JoinHandle::join) {
                tracing::warn!(stage = stage.name(), "stage ended with: {e}");
            }
        }
    }

    fn spawn(&self, stage: Stage) -> Result<StageThread, ChildError> {
        let (run_id, settings, stop) = (
            self.run_id.clone(),
            self.settings.clone(),
            Arc::clone(&self.stop),
        );
        std::thread::Builder::new()
            .name(format!("gfsvo-{}", stage.name()))
            .spawn(move || {
                let run = IpcRun::new(run_id).map_err(|e| e.to_string())?;
                let ctx = StageContext::<local::Service>::thread(run, stage, settings, stop)
                    .map_err(|e| e.to_string())?;
                run_stage(stage, &ctx).map_err(|e| e.to_string())
            })
            .map_err(|source| ChildError::Spawn {
                path: format!("thread gfsvo-{}", stage.name()).into(),
                source,
            })
    }
}

impl Drop for StageThreads {
    fn drop(&mut self) {
        self.stop();
    }
}
