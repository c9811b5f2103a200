//! A lock that dies with its process: `flock(2)` on a file. A run holds one on its run
//! id and one on its output folder while it lives; the kernel releases them however the
//! process ends (SIGKILL included), so a free lock is proof that its last holder is gone.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// An exclusive lock on a file, released (and the file removed) on drop.
#[derive(Debug)]
pub struct FileLock {
    file: File,
    path: PathBuf,
}

/// Who holds a lock that could not be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Holder {
    /// The holder's process id, when it had written it yet.
    pub pid: Option<u32>,
}

impl std::fmt::Display for Holder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.pid {
            Some(pid) => write!(f, "process {pid}"),
            None => f.write_str("another process"),
        }
    }
}

impl FileLock {
    /// Takes the lock on `path` (created if needed) without waiting, and writes this
    /// process's id into it. `Ok(Err(holder))` when another process holds it.
    ///
    /// # Errors
    /// The I/O error when the file cannot be created or locked.
    pub fn try_acquire(path: &Path) -> std::io::Result<Result<Self, Holder>> {
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)?;
            // SAFETY: flock(2) on a descriptor we own; no memory is touched.
            if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
                let e = std::io::Error::last_os_error();
                if e.raw_os_error() != Some(libc::EWOULDBLOCK) {
                    return Err(e);
                }
                let mut text = String::new();
                let pid = file
                    .read_to_string(&mut text)
                    .ok()
                    .and_then(|_| text.trim().parse().ok());
                return Ok(Err(Holder { pid }));
            }
            // The previous holder removes the file while it still holds the lock: if it
            // did so between our open and our flock, we locked a file nobody else will
            // see; open the new one instead.
            let ours = file.metadata()?;
            match std::fs::metadata(path) {
                Ok(now) if now.ino() == ours.ino() && now.dev() == ours.dev() => {}
                _ => continue,
            }
            file.set_len(0)?;
            write!(file, "{}", std::process::id())?;
            return Ok(Ok(Self {
                file,
                path: path.to_path_buf(),
            }));
        }
    }

    /// The locked file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for FileLock {
    fn drop(&mut self) {
        // Removed while still locked (the descriptor closes after this), so that a
        // process that opened it meanwhile sees the inode change and retries.
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_lock_is_refused_and_names_its_holder() {
        let path = std::env::temp_dir().join(format!("gfs-lock-{}", std::process::id()));
        let lock = FileLock::try_acquire(&path).unwrap().unwrap();
        // A second descriptor of the same process conflicts too (flock is per open file).
        let holder = FileLock::try_acquire(&path).unwrap().unwrap_err();
        assert_eq!(holder.pid, Some(std::process::id()));
        drop(lock);
        assert!(!path.exists(), "the lock file goes with the lock");
        let again = FileLock::try_acquire(&path).unwrap();
        assert!(again.is_ok());
    }
}
