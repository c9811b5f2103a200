//! Who owns a run id, and removing what dead runs left behind.
//!
//! A run claims its id with a [`FileLock`] in [`LOCK_DIR`] for as long as it lives, so a
//! second run with the same id is refused at start. Whatever killed a run (SIGKILL of
//! the supervisor, a stage killed while it set up its node), its iceoryx2 nodes, services
//! and shared memory are removed by the next run or `gfsvo clean` once it is provably
//! dead: its id lock is free, no node of it is alive (iceoryx2's node monitor, or the
//! owner pid of a node that died half-created is gone), and a run with no node at all is
//! left alone while its files are young (it may be starting, without a lock, from an
//! older build). Nothing of a live run is ever touched.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use iceoryx2::node::{DeadNodeView, NodeState, NodeView};
use iceoryx2::prelude::{CallbackProgression, Node, ipc};

use crate::error::IpcError;
use crate::lock::FileLock;
use crate::run::{IPC_ROOT, IpcRun, RunId, SHM_DIR};

/// Folder of the run id locks (`<run-id>.lock`).
pub const LOCK_DIR: &str = "/tmp/gfsvo-runs";

/// How long a run waits for its id's lock before it takes the id for in use: longer than
/// another run's sweep holds it to look at the id.
const CLAIM_PATIENCE: Duration = Duration::from_secs(1);

/// Pause between two tries of the id's lock.
const CLAIM_RETRY: Duration = Duration::from_millis(20);

/// A run with no node whose newest file is younger than this may be starting.
pub const STARTING_GRACE: Duration = Duration::from_secs(20);

/// The claim of a run on its id: held while the run lives.
#[derive(Debug)]
pub struct RunClaim {
    _lock: FileLock,
    run: IpcRun,
}

impl RunClaim {
    /// Removes what dead nodes of the run left (call once every process of the run has
    /// exited) and returns the files still there: none after a clean end.
    ///
    /// # Errors
    /// [`IpcError::NodeList`] when the node directory cannot be read.
    pub fn clean_up(&self) -> Result<Vec<PathBuf>, IpcError> {
        remove_if_dead(&self.run, Duration::ZERO)?;
        Ok(self.run.leftovers())
    }
}

/// Whether a run can be removed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Liveness {
    /// Something of it lives (said what); nothing was touched.
    Live(String),
    /// It was dead; its files were removed (how many).
    Removed(usize),
}

impl IpcRun {
    /// Claims the run id for this process, after removing what a dead run with the same
    /// id left behind. Live nodes of the id without its lock are observers (`gfsvo
    /// record`, a test watching the poses): they are left alone and do not refuse it.
    ///
    /// # Errors
    /// [`IpcError::RunInUse`] when a live run holds the id's lock; [`IpcError::Lock`]
    /// when the lock file cannot be created.
    pub fn claim(&self) -> Result<RunClaim, IpcError> {
        // Another run's sweep holds the lock while it checks whether this id is dead (a
        // few milliseconds); only a lock held past that is a live run.
        let deadline = Instant::now() + CLAIM_PATIENCE;
        let lock = loop {
            match lock_run(self.run_id())? {
                Ok(lock) => break lock,
                Err(_) if Instant::now() < deadline => std::thread::sleep(CLAIM_RETRY),
                Err(by) => {
                    return Err(IpcError::RunInUse {
                        run: self.run_id().to_string(),
                        by,
                    });
                }
            }
        };
        match remove_if_dead(self, Duration::ZERO)? {
            Liveness::Live(who) => {
                tracing::debug!(run = %self.run_id(), "files kept: {who}");
            }
            Liveness::Removed(n) if n > 0 => {
                tracing::info!(run = %self.run_id(), "removed {n} files a dead run left");
            }
            Liveness::Removed(_) => {}
        }
        Ok(RunClaim {
            _lock: lock,
            run: self.clone(),
        })
    }

    /// Removes every file of the run if no node of it lives (for a process that observed
    /// a run it does not own, like `gfsvo record`, once its own node is gone).
    ///
    /// # Errors
    /// [`IpcError::NodeList`] when the node directory cannot be read.
    pub fn remove_if_unused(&self) -> Result<Liveness, IpcError> {
        remove_if_dead(self, Duration::ZERO)
    }
}

/// What [`sweep_dead_runs`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SweepReport {
    /// Dead runs whose files were removed, with the number of files.
    pub removed: Vec<(RunId, usize)>,
    /// Runs left alone, with the reason.
    pub live: Vec<(RunId, String)>,
}

/// Removes the files of every dead run on this machine (see the module documentation);
/// runs that live, or that this process holds, are left alone.
pub fn sweep_dead_runs() -> SweepReport {
    let mut report = SweepReport::default();
    for id in runs_on_disk() {
        let Ok(run) = IpcRun::new(id.clone()) else {
            continue;
        };
        let lock = match lock_run(&id) {
            Ok(Ok(lock)) => lock,
            Ok(Err(by)) => {
                report.live.push((id, by));
                continue;
            }
            Err(e) => {
                report.live.push((id, e.to_string()));
                continue;
            }
        };
        match remove_if_dead(&run, STARTING_GRACE) {
            Ok(Liveness::Removed(n)) => report.removed.push((id, n)),
            Ok(Liveness::Live(why)) => report.live.push((id, why)),
            Err(e) => report.live.push((id, e.to_string())),
        }
        drop(lock);
    }
    report
}

/// Takes the lock of `id`: `Ok(Err(holder))` when a live process holds it.
fn lock_run(id: &RunId) -> Result<Result<FileLock, String>, IpcError> {
    let path = Path::new(LOCK_DIR).join(format!("{id}.lock"));
    let io = |source| IpcError::Lock {
        path: path.clone(),
        source,
    };
    std::fs::create_dir_all(LOCK_DIR).map_err(io)?;
    Ok(FileLock::try_acquire(&path)
        .map_err(io)?
        .map_err(|holder| format!("{holder} (lock {})", path.display())))
}

/// Removes every file of `run` if nothing of it lives. A run without any node counts as
/// live while a file of it is younger than `grace`.
fn remove_if_dead(run: &IpcRun, grace: Duration) -> Result<Liveness, IpcError> {
    // Listed first: a file made after this (a process joining the run meanwhile, whose
    // node the scan below may have missed) is never removed.
    let found = run.leftovers();
    let nodes = scan(run)?;
    if let Some(why) = nodes.live {
        return Ok(Liveness::Live(why));
    }
    if nodes.dead.is_empty() && nodes.half_made.is_empty() {
        if found.is_empty() {
            return Ok(Liveness::Removed(0));
        }
        if younger_than(&found, grace) {
            return Ok(Liveness::Live("no node yet, files just made".to_owned()));
        }
    }
    for view in nodes.dead {
        if let Err(e) = view.try_remove_stale_resources() {
            tracing::warn!(run = %run.run_id(), "dead node cleanup failed: {e:?}");
        }
    }
    let prefix = run.file_prefix();
    for id in nodes.half_made {
        remove_prefixed_in(
            &Path::new(IPC_ROOT).join("nodes").join(id.to_string()),
            &prefix,
        );
    }
    if let Some(why) = scan(run)?.live {
        return Ok(Liveness::Live(why));
    }
    for path in run.leftovers().iter().filter(|p| found.contains(p)) {
        let removed = if path.is_dir() {
            std::fs::remove_dir_all(path)
        } else {
            std::fs::remove_file(path)
        };
        if let Err(e) = removed {
            tracing::warn!(run = %run.run_id(), "cannot remove {}: {e}", path.display());
        }
        remove_empty_node_dir(path);
    }
    Ok(Liveness::Removed(found.len()))
}

/// The nodes of a run, sorted by what can be done with them.
struct Scan {
    /// Why the run counts as live, if it does.
    live: Option<String>,
    /// Nodes whose process died: iceoryx2 removes their resources.
    dead: Vec<DeadNodeView<ipc::Service>>,
    /// Node folders (by id) whose process died while it made them.
    half_made: Vec<u128>,
}

fn scan(run: &IpcRun) -> Result<Scan, IpcError> {
    let mut nodes = Scan {
        live: None,
        dead: Vec::new(),
        half_made: Vec::new(),
    };
    Node::<ipc::Service>::list(run.config(), |state| {
        match state {
            NodeState::Alive(view) => {
                let pid = NodeView::details(&view)
                    .as_ref()
                    .map(|d| d.process_id().value());
                nodes.live = Some(format!("a live node (pid {pid:?})"));
            }
            NodeState::Dead(view) => nodes.dead.push(view),
            NodeState::Inaccessible(id) => nodes.live = Some(format!("inaccessible node {id}")),
            NodeState::Undefined(id) => match id.pid::<ipc::Service>() {
                Ok(pid) if process_alive(pid.value()) => {
                    nodes.live = Some(format!("a node being made by pid {}", pid.value()));
                }
                _ => nodes.half_made.push(id.value()),
            },
        }
        if nodes.live.is_some() {
            CallbackProgression::Stop
        } else {
            CallbackProgression::Continue
        }
    })
    .map_err(|reason| IpcError::NodeList {
        run: run.run_id().to_string(),
        reason,
    })?;
    Ok(nodes)
}

/// Removes the entries of `dir` named `prefix...`, then `dir` itself if empty.
fn remove_prefixed_in(dir: &Path, prefix: &str) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            if entry.file_name().to_string_lossy().starts_with(prefix) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    let _ = std::fs::remove_dir(dir);
}

/// A node's files live in `<root>/nodes/<node id>/`: that folder goes with its last file.
fn remove_empty_node_dir(file: &Path) {
    let nodes = Path::new(IPC_ROOT).join("nodes");
    if let Some(dir) = file
        .parent()
        .filter(|d| d.parent() == Some(nodes.as_path()))
    {
        let _ = std::fs::remove_dir(dir);
    }
}

fn younger_than(files: &[PathBuf], grace: Duration) -> bool {
    let now = SystemTime::now();
    files.iter().any(|f| {
        std::fs::symlink_metadata(f)
            .and_then(|m| m.modified())
            .is_ok_and(|t| now.duration_since(t).unwrap_or_default() < grace)
    })
}

/// True while a process with this id exists (EPERM: it exists, owned by someone else).
fn process_alive(pid: i32) -> bool {
    // SAFETY: kill(2) with signal 0 only checks the process; no memory is touched.
    pid > 0
        && (unsafe { libc::kill(pid, 0) } == 0
            || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM))
}

/// Every run id with a file in `/dev/shm`, `/tmp/iceoryx2` or a lock in [`LOCK_DIR`].
pub fn runs_on_disk() -> Vec<RunId> {
    let mut names = Vec::new();
    let root = Path::new(IPC_ROOT);
    let nodes = root.join("nodes");
    let mut dirs = vec![
        PathBuf::from(SHM_DIR),
        root.to_path_buf(),
        root.join("services"),
    ];
    if let Ok(entries) = std::fs::read_dir(&nodes) {
        dirs.extend(entries.flatten().map(|e| e.path()));
    }
    for dir in dirs {
        if let Ok(entries) = std::fs::read_dir(dir) {
            names.extend(entries.flatten().map(|e| e.file_name()));
        }
    }
    let mut ids: Vec<RunId> = names
        .iter()
        .filter_map(|n| n.to_str()?.strip_prefix("gfsvo_")?.split('_').next())
        .chain(lock_ids().iter().map(String::as_str))
        .filter_map(|id| RunId::new(id).ok())
        .collect();
    ids.sort_by(|a, b| a.as_str().cmp(b.as_str()));
    ids.dedup();
    ids
}

fn lock_ids() -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(LOCK_DIR) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_str()?.to_owned();
            Some(name.strip_suffix(".lock")?.to_owned())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(tag: &str) -> IpcRun {
        let id = format!("sw{tag}{}", std::process::id() % 100_000);
        IpcRun::new(RunId::new(&id).unwrap()).unwrap()
    }

    #[test]
    fn a_claim_waits_out_another_runs_brief_look_at_the_id() {
        let run = run("brief");
        // Another run's sweep holds the id's lock while it looks at it.
        let probe = lock_run(run.run_id()).unwrap().unwrap();
        let release = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(200));
            drop(probe);
        });
        let claim = run.claim();
        release.join().unwrap();
        assert!(claim.is_ok(), "{claim:?}");
    }

    #[test]
    fn a_lock_held_past_the_patience_is_a_run_in_use() {
        let run = run("held");
        let _held = lock_run(run.run_id()).unwrap().unwrap();
        let claim = run.claim();
        assert!(matches!(claim, Err(IpcError::RunInUse { .. })), "{claim:?}");
    }
}
