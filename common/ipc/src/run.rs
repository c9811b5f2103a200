//! Run isolation: every run (a `gfsvo run`, a test) gets its own iceoryx2 file prefix,
//! so two runs on one machine never see each other's services or nodes, and "is anything
//! of this run left?" is a directory listing.
//!
//! iceoryx2 0.10 names every shared-memory object `/dev/shm/<prefix>...`, every file
//! `<root>/{nodes,services}/<prefix>...` and every event socket `<root><prefix>...`, where
//! `<prefix>` is `Config::global.prefix` (default `iox2_`) and `<root>` the root path
//! (default `/tmp/iceoryx2/`). A run uses prefix `gfsvo_<run-id>_` under the default
//! root. A per-run root directory would be tidier but does not fit: event sockets are
//! Unix datagram sockets whose whole path (root + prefix + 39-digit listener id +
//! `.event`) must fit the 107 bytes of `sun_path`, which is also why run ids are at most
//! 32 characters. Service names are additionally `gfsvo/<run-id>/<topic>` so that logs
//! say which run they are about.

use std::path::{Path, PathBuf};
use std::time::Duration;

use iceoryx2::config::Config;
use iceoryx2::node::{NodeBuilder, NodeState, NodeView, NodeWaitFailure};
use iceoryx2::prelude::{
    CallbackProgression, FileName, Node, NodeName, SemanticString, ServiceName, SignalHandlingMode,
};
use iceoryx2::service::Service;

use crate::error::IpcError;
use crate::header::Stage;

/// Environment variable through which a supervisor hands its run id to the stage
/// processes it starts.
pub const RUN_ID_ENV: &str = "GFSVO_IPC_RUN";

/// Directory under which every run keeps its iceoryx2 files.
pub const IPC_ROOT: &str = "/tmp/iceoryx2";

/// Directory holding POSIX shared-memory objects on Linux.
pub const SHM_DIR: &str = "/dev/shm";

/// Longest run id: the longest event socket path, `/tmp/iceoryx2/gfsvo_<id>_<39 digits>.event`,
/// then stays within the 107 usable bytes of a Unix socket path (98 bytes).
pub const MAX_RUN_ID_LEN: usize = 32;

/// The id of one run: 1..=32 characters of `[A-Za-z0-9-]`. No `_`: the run's file prefix
/// `gfsvo_<id>_` then never is the beginning of another run's prefix.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct RunId(String);

impl RunId {
    /// Validates `id`.
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] when empty, longer than [`MAX_RUN_ID_LEN`] or holding a
    /// character outside `[A-Za-z0-9-]`.
    pub fn new(id: &str) -> Result<Self, IpcError> {
        let invalid = |reason: &str| IpcError::InvalidName {
            what: "run id",
            value: id.to_string(),
            reason: reason.to_string(),
        };
        if id.is_empty() || id.len() > MAX_RUN_ID_LEN {
            return Err(invalid("length must be 1..=32"));
        }
        if !id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-') {
            return Err(invalid("only [A-Za-z0-9-] are allowed"));
        }
        Ok(Self(id.to_string()))
    }

    /// A run id unique on this machine: `<tag>-<pid>-<monotonic ns in hex>` (tag
    /// truncated so the whole fits [`MAX_RUN_ID_LEN`]). For tests and for `gfsvo run`
    /// without an explicit id.
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] when `tag` holds a character outside `[A-Za-z0-9-]`.
    pub fn unique(tag: &str) -> Result<Self, IpcError> {
        let suffix = format!("-{}-{:x}", std::process::id(), crate::monotonic_ns());
        let keep = MAX_RUN_ID_LEN.saturating_sub(suffix.len()).min(tag.len());
        let tag = tag.get(..keep).unwrap_or("run");
        Self::new(&format!("{tag}{suffix}"))
    }

    /// The run id in [`RUN_ID_ENV`], if set.
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] when the variable is set but not a valid run id (also
    /// when it is not UTF-8).
    pub fn from_env() -> Result<Option<Self>, IpcError> {
        match std::env::var(RUN_ID_ENV) {
            Ok(v) => Self::new(&v).map(Some),
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(v)) => Err(IpcError::InvalidName {
                what: "run id",
                value: v.to_string_lossy().into_owned(),
                reason: "not UTF-8".to_string(),
            }),
        }
    }

    /// The id as text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for RunId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Result of a dead-node cleanup pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// Dead nodes whose resources were removed.
    pub cleaned: usize,
    /// Dead nodes that could not be cleaned (permissions, another cleaner busy).
    pub failed: usize,
}

/// A node of the run as seen by [`IpcRun::nodes`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeInfo {
    /// Node name (the stage name for the pipeline's nodes); empty when unknown.
    pub name: String,
    /// Process id of the owner; `None` when the details are unreadable.
    pub pid: Option<i32>,
    /// False when the owning process died without cleaning up.
    pub alive: bool,
}

/// The iceoryx2 setting of one run: its [`RunId`] and the `Config` (file prefix)
/// every node of the run must be created with.
#[derive(Clone, Debug)]
pub struct IpcRun {
    run_id: RunId,
    config: Config,
}

impl IpcRun {
    /// The setting for `run_id`: default iceoryx2 config (root `/tmp/iceoryx2/`) with
    /// prefix `gfsvo_<run-id>_`. Nothing is created on disk yet.
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] if iceoryx2 rejects the prefix (cannot happen for a
    /// valid [`RunId`], but iceoryx2 checks its own rules).
    pub fn new(run_id: RunId) -> Result<Self, IpcError> {
        let mut config = Config::default();
        let prefix = prefix_of(&run_id);
        config.global.prefix =
            FileName::new(prefix.as_bytes()).map_err(|e| IpcError::InvalidName {
                what: "prefix",
                value: prefix.clone(),
                reason: format!("{e:?}"),
            })?;
        Ok(Self { run_id, config })
    }

    /// The run id.
    pub fn run_id(&self) -> &RunId {
        &self.run_id
    }

    /// The iceoryx2 config of the run (for `NodeBuilder::config`, `Node::list`).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The file-name prefix of every iceoryx2 object of the run.
    pub fn file_prefix(&self) -> String {
        prefix_of(&self.run_id)
    }

    /// The service name of `topic` in this run: `gfsvo/<run-id>/<topic>`.
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] when iceoryx2 rejects the name (empty topic, too long).
    pub fn service_name(&self, topic: &str) -> Result<ServiceName, IpcError> {
        let name = format!("gfsvo/{}/{topic}", self.run_id);
        if topic.is_empty() {
            return Err(IpcError::InvalidName {
                what: "service name",
                value: name,
                reason: "empty topic".to_string(),
            });
        }
        ServiceName::new(&name).map_err(|e| IpcError::InvalidName {
            what: "service name",
            value: name.clone(),
            reason: format!("{e:?}"),
        })
    }

    /// Creates the node `name` of this run over the service variant `S`
    /// (`ipc::Service` between processes, `local::Service` between threads).
    ///
    /// Signal handling is left to the caller (`SignalHandlingMode::Disabled`): a library
    /// or a test must not take signals over. Stage processes use [`Self::stage_node`].
    ///
    /// # Errors
    /// [`IpcError::InvalidName`] for a bad node name, [`IpcError::Node`] when iceoryx2
    /// cannot create the node (permissions, corrupted run directory).
    pub fn node<S: Service>(&self, name: &str) -> Result<Node<S>, IpcError> {
        self.build_node(name, SignalHandlingMode::Disabled)
    }

    fn build_node<S: Service>(
        &self,
        name: &str,
        signals: SignalHandlingMode,
    ) -> Result<Node<S>, IpcError> {
        let node_name = NodeName::new(name).map_err(|e| IpcError::InvalidName {
            what: "node name",
            value: name.to_string(),
            reason: format!("{e:?}"),
        })?;
        NodeBuilder::new()
            .name(&node_name)
            .config(&self.config)
            .signal_handling_mode(signals)
            .create::<S>()
            .map_err(|reason| IpcError::Node {
                run: self.run_id.to_string(),
                node: name.to_string(),
                reason,
            })
    }

    /// Creates the node of a pipeline stage process, named after the stage, with
    /// iceoryx2's SIGINT / SIGTERM handlers installed: after such a signal the next
    /// `node.wait(..)` returns `Err(NodeWaitFailure::TerminationRequest)`, so the stage
    /// loop ends, drops its ports and exits cleanly instead of dying with its resources
    /// left behind. The request is reported once (iceoryx2 resets it when read): stop on
    /// the first one.
    ///
    /// # Errors
    /// As [`Self::node`]; [`IpcError::TerminationRequested`] when a signal arrived while
    /// the handlers were being installed.
    pub fn stage_node<S: Service>(&self, stage: Stage) -> Result<Node<S>, IpcError> {
        let node = self.build_node(stage.name(), SignalHandlingMode::HandleTerminationRequests)?;
        // iceoryx2 installs its handlers on the first termination check; do it now so a
        // SIGTERM before the stage loop's first wait is caught rather than fatal.
        match node.wait(Duration::ZERO) {
            Err(NodeWaitFailure::TerminationRequest) => Err(IpcError::TerminationRequested {
                run: self.run_id.to_string(),
                node: stage.name().to_string(),
            }),
            Ok(()) | Err(NodeWaitFailure::Interrupt) => Ok(node),
        }
    }

    /// Every node of the run with its liveness (a dead node's process died without
    /// cleaning up, e.g. SIGKILL).
    ///
    /// # Errors
    /// [`IpcError::NodeList`] when the node directory cannot be read.
    pub fn nodes<S: Service>(&self) -> Result<Vec<NodeInfo>, IpcError> {
        let mut out = Vec::new();
        Node::<S>::list(&self.config, |state| {
            let (details, alive) = match &state {
                NodeState::Alive(v) => (v.details().clone(), true),
                NodeState::Dead(v) => (v.details().clone(), false),
                NodeState::Inaccessible(_) | NodeState::Undefined(_) => (None, false),
            };
            out.push(NodeInfo {
                name: details
                    .as_ref()
                    .map(|d| d.name().as_str().to_string())
                    .unwrap_or_default(),
                pid: details.as_ref().map(|d| d.process_id().value()),
                alive,
            });
            CallbackProgression::Continue
        })
        .map_err(|reason| IpcError::NodeList {
            run: self.run_id.to_string(),
            reason,
        })?;
        Ok(out)
    }

    /// Removes the stale resources of every dead node of the run: its ports are taken
    /// off the services (their loaned / buffered samples return to the publishers), its
    /// shared memory and files are deleted, and a service it was the last user of is
    /// removed. Needs no node of its own, so a supervisor can call it after `waitpid`.
    ///
    /// # Errors
    /// [`IpcError::NodeList`] when the node directory cannot be read.
    pub fn cleanup_dead_nodes<S: Service>(&self) -> Result<CleanupReport, IpcError> {
        let mut report = CleanupReport::default();
        Node::<S>::list(&self.config, |state| {
            if let NodeState::Dead(dead) = state {
                match dead.try_remove_stale_resources() {
                    Ok(()) => report.cleaned += 1,
                    Err(e) => {
                        tracing::warn!(run = %self.run_id, "dead node cleanup failed: {e:?}");
                        report.failed += 1;
                    }
                }
            }
            CallbackProgression::Continue
        })
        .map_err(|reason| IpcError::NodeList {
            run: self.run_id.to_string(),
            reason,
        })?;
        Ok(report)
    }

    /// Every iceoryx2 file or shared-memory object of this run that still exists: the
    /// entries of [`SHM_DIR`] and of [`IPC_ROOT`] (recursively) whose name starts with
    /// the run's prefix. Empty after [`Self::finish`] of a clean or cleaned-up run.
    pub fn leftovers(&self) -> Vec<PathBuf> {
        let prefix = self.file_prefix();
        let mut out = Vec::new();
        collect_prefixed(Path::new(SHM_DIR), &prefix, &mut out);
        collect_prefixed(Path::new(IPC_ROOT), &prefix, &mut out);
        out.sort();
        out
    }

    /// Ends the run's iceoryx2 domain once no process of the run is alive any more
    /// (all stages exited or were killed and [`Self::cleanup_dead_nodes`] ran): removes
    /// the domain's node-counter segment `/dev/shm/<prefix>…_node.<version>.global_mgmt`,
    /// which iceoryx2 0.10 keeps for the lifetime of the domain (no node removes it).
    /// Returns [`Self::leftovers`] afterwards: empty after a clean run. Calling it while
    /// a process of the run is alive breaks that process's node ids.
    pub fn finish(&self) -> Vec<PathBuf> {
        let prefix = self.file_prefix();
        if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if name.starts_with(&prefix)
                    && name.ends_with(GLOBAL_MGMT_SUFFIX)
                    && let Err(e) = std::fs::remove_file(entry.path())
                {
                    tracing::warn!(run = %self.run_id, "cannot remove {name}: {e}");
                }
            }
        }
        self.leftovers()
    }
}

/// Suffix of iceoryx2's per-domain node-counter segment (`Config::global.node.global_mgmt_suffix`).
const GLOBAL_MGMT_SUFFIX: &str = ".global_mgmt";

fn prefix_of(run_id: &RunId) -> String {
    format!("gfsvo_{run_id}_")
}

/// Appends every entry below `dir` (recursively) whose name starts with `prefix`.
fn collect_prefixed(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if entry.file_name().to_string_lossy().starts_with(prefix) {
            out.push(path);
        } else if entry.file_type().is_ok_and(|t| t.is_dir()) {
            collect_prefixed(&path, prefix, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_ids_are_checked() {
        assert!(RunId::new("bench-1a").is_ok());
        assert!(RunId::new("").is_err());
        assert!(RunId::new("a/b").is_err());
        assert!(RunId::new("a_b").is_err());
        assert!(RunId::new(&"x".repeat(33)).is_err());
        let long = RunId::unique(&"t".repeat(100)).unwrap();
        assert!(long.as_str().len() <= MAX_RUN_ID_LEN);
        assert_ne!(RunId::unique("t").unwrap(), RunId::unique("t").unwrap());
    }

    #[test]
    fn names_carry_the_run() {
        let run = IpcRun::new(RunId::new("r1").unwrap()).unwrap();
        assert_eq!(run.file_prefix(), "gfsvo_r1_");
        assert_eq!(
            run.config().global.root_path().as_bytes(),
            b"/tmp/iceoryx2/"
        );
        assert_eq!(
            run.service_name("frame").unwrap().as_str(),
            "gfsvo/r1/frame"
        );
        assert!(run.service_name("").is_err());
        assert_eq!(run.config().global.prefix.as_bytes(), b"gfsvo_r1_");
    }
}
