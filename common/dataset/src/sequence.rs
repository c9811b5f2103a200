//! A TUM RGB-D (or ICL-NUIM TUM-compatible) dataset folder as a sequence of frames.

use crate::DepthConfig;
use crate::decode::{Frame, FrameDecoder};
use crate::error::DatasetError;
use crate::lists::{Entry, read_entries};
use crate::reader::FrameReader;
use gfs_core::camera::{Camera, UndistortMap};
use gfs_core::stamp::Stamp;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Frames the reader thread decodes ahead of the consumer by default: enough to hide a
/// slow file read, few enough to keep memory small (about 2.5 MB per 640x480 frame).
pub const DEFAULT_READ_AHEAD: usize = 3;

/// The frames of a dataset folder: the lists are read at [`Sequence::open`]; images are
/// decoded on demand ([`Sequence::load`]) or ahead on a thread ([`Sequence::frames`]).
///
/// ```no_run
/// use gfs_core::camera::{Camera, PinholeCamera, Distortion};
/// use gfs_dataset::{DepthConfig, Sequence};
/// let camera = Camera {
///     pinhole: PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480),
///     distortion: Distortion::default(),
/// };
/// let seq = Sequence::open("data/fr1_xyz".as_ref(), &camera, &DepthConfig::default())?;
/// let mut reader = seq.frames(None);
/// while let Some(frame) = reader.next() {
///     match frame {
///         Ok(frame) => {
///             println!("frame {} at {:.3} s", frame.id, frame.timestamp);
///             reader.recycle(frame); // its buffers serve a later frame
///         }
///         Err(e) => eprintln!("skipping: {e}"),
///     }
/// }
/// # Ok::<(), gfs_dataset::DatasetError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Sequence {
    dir: PathBuf,
    entries: Arc<[Entry]>,
    timestamps: Vec<Stamp>,
    size: (usize, usize),
    depth: DepthConfig,
    undistort: Option<Arc<UndistortMap>>,
}

impl Sequence {
    /// Reads the lists of a dataset folder (no image decoded yet): `associations.txt` when
    /// present, else `rgb.txt` and `depth.txt` associated by the TUM rule (closest free
    /// stamps within 20 ms). The undistortion table is built here when `camera` has
    /// distortion.
    ///
    /// # Errors
    /// [`DatasetError::MissingList`], [`DatasetError::MalformedLine`],
    /// [`DatasetError::TimestampNotIncreasing`] (file and line), or
    /// [`DatasetError::NoFrames`] for an empty folder or lists that associate nothing.
    pub fn open(
        dir: &Path,
        camera: &Camera,
        depth: &DepthConfig,
    ) -> Result<Sequence, DatasetError> {
        if !dir.is_dir() {
            return Err(DatasetError::NoFrames {
                dir: dir.to_path_buf(),
                reason: "not a folder".to_owned(),
            });
        }
        let entries: Arc<[Entry]> = read_entries(dir)?.into();
        let timestamps = entries.iter().map(|e| e.rgb.stamp).collect();
        let undistort = (!camera.distortion.is_zero()).then(|| Arc::new(UndistortMap::new(camera)));
        Ok(Sequence {
            dir: dir.to_path_buf(),
            entries,
            timestamps,
            size: (camera.pinhole.width, camera.pinhole.height),
            depth: *depth,
            undistort,
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when the sequence has no frame (never after a successful [`Sequence::open`]).
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The dataset folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Colour capture stamps, in frame order.
    pub fn timestamps(&self) -> &[Stamp] {
        &self.timestamps
    }

    /// `groundtruth.txt` of the folder, if there is one.
    pub fn ground_truth_path(&self) -> Option<PathBuf> {
        let path = self.dir.join("groundtruth.txt");
        path.is_file().then_some(path)
    }

    /// Decodes frames on a background thread, [`DEFAULT_READ_AHEAD`] frames ahead of
    /// use; stops after `limit` frames if given. A bad image is an `Err` item and the
    /// iteration goes on with the next frame.
    pub fn frames(&self, limit: Option<usize>) -> FrameReader {
        self.frames_ahead(limit, DEFAULT_READ_AHEAD)
    }

    /// [`Sequence::frames`] with `ahead` frames decoded ahead of use (at least 1).
    pub fn frames_ahead(&self, limit: Option<usize>, ahead: usize) -> FrameReader {
        self.frames_from(0, limit, ahead)
    }

    /// [`Sequence::frames_ahead`] starting at frame `start` (a restarted source resumes
    /// there); `limit` still counts from frame 0.
    pub fn frames_from(&self, start: usize, limit: Option<usize>, ahead: usize) -> FrameReader {
        let total = limit.map_or(self.len(), |l| l.min(self.len()));
        FrameReader::spawn(
            self.decoder(),
            Arc::clone(&self.entries),
            start..total,
            ahead,
        )
    }

    /// Decodes frame `index` on this thread.
    ///
    /// # Errors
    /// [`DatasetError::IndexOutOfRange`], or the error of its colour or depth image:
    /// missing, undecodable, wrong format or size.
    pub fn load(&self, index: usize) -> Result<Frame, DatasetError> {
        let entry = self
            .entries
            .get(index)
            .ok_or(DatasetError::IndexOutOfRange {
                index,
                len: self.len(),
            })?;
        self.decoder().decode(index, entry, None)
    }

    fn decoder(&self) -> FrameDecoder {
        FrameDecoder::new(self.size, self.depth, self.undistort.clone())
    }
}
