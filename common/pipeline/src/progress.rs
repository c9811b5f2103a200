//! The progress board: one shared-memory slot per stage in the run's state folder
//! (`progress.bin`), where each stage notes the last frame it published (and the
//! tracker the last frame it asked a keyframe for). The supervisor reads it to tell a
//! stage that stopped making progress while its input waits (hung, stopped) from one
//! that has nothing to do. Atomic stores into a mapped file: no syscall per frame, and a
//! stage restarted after a kill goes on writing the same slot.

use gfs_ipc::Stage;
use std::fs::OpenOptions;
use std::os::fd::AsRawFd;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// The board's file in the state folder.
pub const BOARD: &str = "progress.bin";

/// Counters of one stage: frame id + 1 (0: none yet).
#[repr(C)]
struct Slot {
    made: AtomicU64,
    requested: AtomicU64,
}

const BYTES: usize = Stage::COUNT * std::mem::size_of::<Slot>();

/// The mapped board.
pub struct ProgressBoard {
    slots: *mut Slot,
}

// SAFETY: the mapping is only accessed through atomics and lives until drop.
unsafe impl Send for ProgressBoard {}
// SAFETY: as above.
unsafe impl Sync for ProgressBoard {}

/// What a stage has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageProgress {
    /// Last frame published + 1 (0: none).
    pub made: u64,
    /// Tracker: last frame a keyframe was requested for + 1 (0: none).
    pub requested: u64,
}

impl ProgressBoard {
    /// Creates a zeroed board in `dir` (the supervisor, before the stages start).
    ///
    /// # Errors
    /// The I/O error when the file cannot be created or mapped.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let path = dir.join(BOARD);
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)?;
        file.set_len(BYTES as u64)?;
        Self::map(&file)
    }

    /// Opens the board in `dir`, if the supervisor made one (a stage).
    pub fn open(dir: &Path) -> Option<Self> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(dir.join(BOARD))
            .ok()?;
        if file.metadata().ok()?.len() < BYTES as u64 {
            return None;
        }
        Self::map(&file).ok()
    }

    fn map(file: &std::fs::File) -> std::io::Result<Self> {
        // SAFETY: a shared mapping of a file at least BYTES long; the pointer is only
        // used through atomics (aligned: mmap returns page-aligned memory).
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                BYTES,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if ptr == libc::MAP_FAILED {
            return Err(std::io::Error::last_os_error());
        }
        Ok(Self {
            slots: ptr.cast::<Slot>(),
        })
    }

    fn slot(&self, stage: Stage) -> &Slot {
        // SAFETY: index < Stage::COUNT, inside the mapping, which outlives `self`.
        unsafe { &*self.slots.add(stage.index()) }
    }

    /// `stage` published frame `frame`.
    pub fn made(&self, stage: Stage, frame: u64) {
        self.slot(stage)
            .made
            .fetch_max(frame + 1, Ordering::Relaxed);
    }

    /// The tracker asked for frame `frame` to become a keyframe.
    pub fn requested(&self, frame: u64) {
        self.slot(Stage::Tracker)
            .requested
            .fetch_max(frame + 1, Ordering::Relaxed);
    }

    /// What `stage` has done.
    pub fn read(&self, stage: Stage) -> StageProgress {
        let slot = self.slot(stage);
        StageProgress {
            made: slot.made.load(Ordering::Relaxed),
            requested: slot.requested.load(Ordering::Relaxed),
        }
    }
}

impl Drop for ProgressBoard {
    fn drop(&mut self) {
        // SAFETY: unmaps exactly the mapping made in `map`.
        unsafe {
            libc::munmap(self.slots.cast(), BYTES);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_and_the_supervisor_share_the_board() {
        let dir = std::env::temp_dir().join(format!("gfs-board-{}", std::process::id()));
        let supervisor = ProgressBoard::create(&dir).unwrap();
        let stage = ProgressBoard::open(&dir).unwrap();
        stage.made(Stage::Lines, 4);
        stage.made(Stage::Lines, 2);
        stage.requested(7);
        assert_eq!(supervisor.read(Stage::Lines).made, 5, "never goes back");
        assert_eq!(supervisor.read(Stage::Tracker).requested, 8);
        assert_eq!(supervisor.read(Stage::Points), StageProgress::default());
        std::fs::remove_dir_all(dir).unwrap();
    }
}
