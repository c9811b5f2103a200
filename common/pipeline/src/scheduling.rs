//! `[pipeline.scheduling]`: how the operating system schedules each stage process.
//!
//! **Why.** On a small board the per-frame path (source, points, lines, planes,
//! tracker) and the per-keyframe work (mapper) share a few cores. A keyframe's local
//! mapping takes 15-40 ms; if it runs at the same priority as the front end of the next
//! frames, those frames wait behind it and their poses come late. Giving the mapper a
//! higher nice level lets the frame path take the CPU first, while the mapper still
//! gets what the frame path leaves (a few ms per frame at 30 Hz). The supervisor applies
//! these settings between fork and exec, so every thread of a stage inherits them; the
//! systemd units in `deploy/systemd/` carry the same defaults as `Nice=`,
//! `CPUSchedulingPolicy=` and `CPUAffinity=`.

use gfs_ipc::Stage;
use serde::Deserialize;
use std::collections::BTreeMap;

/// The nice level of the per-keyframe stages by default. With Linux's CFS weights, a
/// nice-10 process gets about a tenth of a core that a nice-0 process also wants, and
/// all of a core that no one else wants. Measured on two cores (docs/results.md, "Latency").
pub const KEYFRAME_STAGE_NICE: i32 = 10;

/// CPUs a `cpu_set_t` can name.
const MAX_CPUS: usize = 8 * std::mem::size_of::<libc::cpu_set_t>();

/// A Linux scheduling policy (`sched(7)`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Policy {
    /// `SCHED_OTHER`: the default time sharing, weighted by the nice level.
    #[default]
    Other,
    /// `SCHED_BATCH`: time sharing for CPU-bound work that may wake up late.
    Batch,
    /// `SCHED_IDLE`: runs only when nothing else wants the CPU (a stage under this
    /// policy can starve on a busy machine).
    Idle,
    /// `SCHED_FIFO` real time with `priority` (needs `CAP_SYS_NICE`).
    Fifo,
    /// `SCHED_RR` real time with `priority` (needs `CAP_SYS_NICE`).
    Rr,
}

impl Policy {
    fn libc(self) -> libc::c_int {
        match self {
            Self::Other => libc::SCHED_OTHER,
            Self::Batch => libc::SCHED_BATCH,
            Self::Idle => libc::SCHED_IDLE,
            Self::Fifo => libc::SCHED_FIFO,
            Self::Rr => libc::SCHED_RR,
        }
    }

    fn is_real_time(self) -> bool {
        matches!(self, Self::Fifo | Self::Rr)
    }

    /// The name systemd's `CPUSchedulingPolicy=` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Other => "other",
            Self::Batch => "batch",
            Self::Idle => "idle",
            Self::Fifo => "fifo",
            Self::Rr => "rr",
        }
    }
}

/// `[pipeline.scheduling.<stage>]` as written: every field optional, so that a table
/// changes only what it names and keeps the stage's default for the rest.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StageSchedulingToml {
    /// Nice level, -20 (first) ..= 19 (last); below the supervisor's own level it needs
    /// `CAP_SYS_NICE`.
    pub nice: Option<i32>,
    /// Scheduling policy: `other`, `batch`, `idle`, `fifo` or `rr`.
    pub policy: Option<Policy>,
    /// Real-time priority 1 ..= 99 for `fifo` / `rr`.
    pub priority: Option<u8>,
    /// CPUs the stage may run on (indices); empty: all.
    pub cpus: Option<Vec<usize>>,
}

/// How one stage is scheduled.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageScheduling {
    /// Nice level (-20 ..= 19).
    pub nice: i32,
    /// Scheduling policy.
    pub policy: Policy,
    /// Real-time priority (1 ..= 99) for `fifo` / `rr`, else 0.
    pub priority: u8,
    /// CPUs the stage may run on; empty: all.
    pub cpus: Vec<usize>,
}

/// `[pipeline.scheduling]`: one optional table per stage, by stage name.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(transparent)]
pub struct SchedulingConfig {
    stages: BTreeMap<String, StageSchedulingToml>,
}

/// A scheduling setting that cannot be applied as written.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum SchedulingConfigError {
    /// A table names no stage.
    #[error("pipeline.scheduling.{0}: no such stage (expected one of {list})", list = stage_names())]
    UnknownStage(String),
    /// A value is out of range or contradicts another.
    #[error("pipeline.scheduling.{stage}.{field}: {reason}")]
    Invalid {
        /// The stage table.
        stage: String,
        /// The field.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
}

fn stage_names() -> String {
    Stage::ALL.map(Stage::name).join(", ")
}

impl SchedulingConfig {
    /// The defaults of a stage: the frame path at nice 0, the per-keyframe work at
    /// [`KEYFRAME_STAGE_NICE`]; every stage on every CPU, `SCHED_OTHER`.
    pub fn default_for(stage: Stage) -> StageScheduling {
        StageScheduling {
            nice: match stage {
                Stage::Mapper | Stage::Loop => KEYFRAME_STAGE_NICE,
                _ => 0,
            },
            ..StageScheduling::default()
        }
    }

    /// The scheduling of `stage`: its default overlaid with what its table sets.
    pub fn for_stage(&self, stage: Stage) -> StageScheduling {
        let mut resolved = Self::default_for(stage);
        if let Some(set) = self.stages.get(stage.name()) {
            resolved.nice = set.nice.unwrap_or(resolved.nice);
            resolved.policy = set.policy.unwrap_or(resolved.policy);
            resolved.priority = set.priority.unwrap_or(resolved.priority);
            resolved.cpus = set.cpus.clone().unwrap_or(resolved.cpus);
        }
        resolved
    }

    /// Checks stage names, ranges and that the priority fits the policy.
    ///
    /// # Errors
    /// [`SchedulingConfigError`] naming the table and field.
    pub fn validate(&self) -> Result<(), SchedulingConfigError> {
        for name in self.stages.keys() {
            let stage = Stage::from_name(name)
                .ok_or_else(|| SchedulingConfigError::UnknownStage(name.clone()))?;
            let s = self.for_stage(stage);
            let invalid = |field, reason: String| SchedulingConfigError::Invalid {
                stage: name.clone(),
                field,
                reason,
            };
            if !(-20..=19).contains(&s.nice) {
                return Err(invalid("nice", format!("{} is outside -20..=19", s.nice)));
            }
            match (s.policy.is_real_time(), s.priority) {
                (true, 1..=99) | (false, 0) => {}
                (true, p) => {
                    return Err(invalid(
                        "priority",
                        format!("{p} is outside 1..=99 for policy {}", s.policy.name()),
                    ));
                }
                (false, p) => {
                    return Err(invalid(
                        "priority",
                        format!("{p} needs policy fifo or rr, not {}", s.policy.name()),
                    ));
                }
            }
            if let Some(cpu) = s.cpus.iter().find(|c| **c >= MAX_CPUS) {
                return Err(invalid(
                    "cpus",
                    format!("CPU {cpu} is not below {MAX_CPUS}"),
                ));
            }
        }
        Ok(())
    }
}

impl StageScheduling {
    /// What the process must be told, prepared before `fork` so that
    /// [`PreparedScheduling::apply_to_this_process`] allocates nothing.
    pub fn prepare(&self) -> PreparedScheduling {
        let cpus = (!self.cpus.is_empty()).then(|| {
            // SAFETY: an all-zero cpu_set_t is the valid empty set.
            let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
            for &cpu in self.cpus.iter().filter(|c| **c < MAX_CPUS) {
                // SAFETY: `cpu` is inside the set (checked above).
                unsafe { libc::CPU_SET(cpu, &mut set) };
            }
            set
        });
        PreparedScheduling {
            nice: self.nice,
            policy: self.policy.libc(),
            priority: libc::c_int::from(self.priority),
            cpus,
        }
    }

    /// Reads how process `pid` is scheduled now and names each setting that differs
    /// from `self` (a setting the OS refused, e.g. a negative nice level or a real-time
    /// policy without `CAP_SYS_NICE`, or CPUs that do not exist).
    pub fn differences(&self, pid: i32) -> Vec<String> {
        let mut found = Vec::new();
        // SAFETY: plain syscalls on a pid; errors are reported through errno/-1.
        let (policy, nice) = unsafe {
            *libc::__errno_location() = 0;
            let nice = libc::getpriority(libc::PRIO_PROCESS, pid as libc::id_t);
            (libc::sched_getscheduler(pid), nice)
        };
        if policy >= 0 && policy != self.policy.libc() {
            found.push(format!("policy {} not applied", self.policy.name()));
        }
        let uses_nice = !self.policy.is_real_time() && self.policy != Policy::Idle;
        if uses_nice && nice != self.nice {
            found.push(format!(
                "nice {} not applied (running at {nice})",
                self.nice
            ));
        }
        if !self.cpus.is_empty() {
            // SAFETY: the set is a plain bitmask the kernel fills.
            let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
            let size = std::mem::size_of::<libc::cpu_set_t>();
            // SAFETY: `set` is valid for `size` bytes.
            let read = unsafe { libc::sched_getaffinity(pid, size, &mut set) };
            let wanted = self.prepare().cpus;
            if read == 0 && wanted.is_some_and(|w| !cpu_sets_equal(&w, &set)) {
                found.push(format!("cpus {:?} not applied", self.cpus));
            }
        }
        found
    }
}

fn cpu_sets_equal(a: &libc::cpu_set_t, b: &libc::cpu_set_t) -> bool {
    // SAFETY: every index is inside the set.
    (0..MAX_CPUS).all(|c| unsafe { libc::CPU_ISSET(c, a) == libc::CPU_ISSET(c, b) })
}

/// A [`StageScheduling`] as the system calls take it.
#[derive(Clone, Copy)]
pub struct PreparedScheduling {
    nice: i32,
    policy: libc::c_int,
    priority: libc::c_int,
    cpus: Option<libc::cpu_set_t>,
}

impl PreparedScheduling {
    /// Applies the settings to the calling process (thread) and so to every thread it
    /// starts later. Only system calls: safe between `fork` and `exec`. A refused
    /// setting is left as it was; [`StageScheduling::differences`] reports it.
    pub fn apply_to_this_process(&self) {
        // SAFETY: sched_setaffinity / sched_setscheduler / setpriority on pid 0 (this
        // process) with valid, initialised arguments; failures only return -1.
        unsafe {
            if let Some(set) = &self.cpus {
                libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), set);
            }
            let param = libc::sched_param {
                sched_priority: self.priority,
            };
            libc::sched_setscheduler(0, self.policy, &param);
            libc::setpriority(libc::PRIO_PROCESS, 0, self.nice);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> SchedulingConfig {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn the_keyframe_stages_yield_to_the_frame_path_by_default() {
        let config = SchedulingConfig::default();
        for stage in Stage::ALL {
            let s = config.for_stage(stage);
            assert_eq!(s.policy, Policy::Other);
            assert!(s.cpus.is_empty());
            let expected = if matches!(stage, Stage::Mapper | Stage::Loop) {
                10
            } else {
                0
            };
            assert_eq!(s.nice, expected, "{}", stage.name());
        }
    }

    #[test]
    fn a_table_changes_only_what_it_names() {
        let config = parse("[mapper]\ncpus = [1]\n[points]\nnice = 3\n");
        config.validate().unwrap();
        let mapper = config.for_stage(Stage::Mapper);
        assert_eq!((mapper.nice, mapper.cpus.as_slice()), (10, &[1][..]));
        assert_eq!(config.for_stage(Stage::Points).nice, 3);
        assert_eq!(config.for_stage(Stage::Lines).nice, 0);
    }

    #[test]
    fn bad_settings_name_stage_and_field() {
        let cases = [
            ("[mapper]\nnice = 20\n", "pipeline.scheduling.mapper.nice"),
            (
                "[tracker]\npolicy = \"fifo\"\n",
                "pipeline.scheduling.tracker.priority",
            ),
            (
                "[tracker]\npriority = 5\n",
                "pipeline.scheduling.tracker.priority",
            ),
            (
                "[lines]\ncpus = [100000]\n",
                "pipeline.scheduling.lines.cpus",
            ),
            ("[mappr]\nnice = 1\n", "pipeline.scheduling.mappr"),
        ];
        for (text, field) in cases {
            let e = parse(text).validate().unwrap_err().to_string();
            assert!(e.starts_with(field), "{text}: {e}");
        }
        assert!(toml::from_str::<SchedulingConfig>("[mapper]\npolicy = \"fast\"\n").is_err());
    }

    #[test]
    fn a_thread_gets_its_nice_level_and_a_difference_is_reported() {
        let pid = std::process::id() as i32;
        // SAFETY: reads this process's nice level.
        let mine = unsafe { libc::getpriority(libc::PRIO_PROCESS, 0) };
        // Raising the nice level is always allowed; check on a child so that this test
        // process keeps its own.
        let child = std::thread::spawn(move || {
            let wanted = StageScheduling {
                nice: (mine + 2).min(19),
                ..StageScheduling::default()
            };
            wanted.prepare().apply_to_this_process();
            // SAFETY: gettid has no preconditions.
            let tid = unsafe { libc::gettid() };
            wanted.differences(tid)
        });
        assert_eq!(child.join().unwrap(), Vec::<String>::new());
        let impossible = StageScheduling {
            nice: mine,
            policy: Policy::Batch,
            ..StageScheduling::default()
        };
        assert_eq!(impossible.differences(pid), ["policy batch not applied"]);
    }
}
