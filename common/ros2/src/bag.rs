//! ROS 2 bags in MCAP: reading the colour / depth / camera-info topics of a bag (a bag
//! folder with `metadata.yaml` and `.mcap` files, or a bare `.mcap`) as a sequence of
//! paired frames, raw or as `image_transport` compressed them (each topic's schema says
//! which), from uncompressed, zstd or lz4 chunks; and writing bags ([`BagWriter`]).
//! A bag that did not finish (no footer) is refused as truncated; a malformed one is an
//! error naming the file and the byte offset, whatever its length fields say.

use crate::bag_records::{ChannelInfo, RecordMessage, Records, summary_channels, summary_start};
pub use crate::bag_writer::{BagWriter, Compression};
use crate::cdr::{self, CdrError};
use crate::config::Transport;
use crate::imu::{ImuInput, ImuTopic, ImuTopics};
use crate::msg::{CameraInfo, CompressedImage, Image, Imu};
use crate::pairing::{Paired, Pairer};
use crate::transport::TransportImage;
use gfs_core::stamp::Stamp;
use gfs_inertial::{ImuFeed, ImuSample};
use std::collections::{BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

/// A bag cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// No `.mcap` file where the bag should be.
    #[error("{path}: not a ROS 2 bag (a folder with .mcap files, or an .mcap file)")]
    NotABag {
        /// The path given.
        path: PathBuf,
    },
    /// I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("{path}: {message}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What the MCAP writer said.
        message: String,
    },
    /// The file does not end as a complete MCAP file does.
    #[error("{path}: truncated ({size} bytes): {reason}")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Its size.
        size: u64,
        /// What is missing.
        reason: String,
    },
    /// A record is malformed.
    #[error("{path}: corrupt at byte {offset}: {reason}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// How far the file was read.
        offset: u64,
        /// What is wrong.
        reason: String,
    },
    /// A topic the run needs has no message.
    #[error("{path}: no message on {topic} (topics in the bag: {found})")]
    MissingTopic {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The topics the bag has.
        found: String,
    },
    /// A topic the run reads carries another message type.
    #[error("{path}: {topic} carries {schema}, not {expected}")]
    Schema {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Its schema name.
        schema: String,
        /// What the topic must carry.
        expected: &'static str,
    },
    /// A payload is not a CDR message of the topic's type.
    #[error("{path}: {topic} at log time {log_time_ns} ns: {source}")]
    Payload {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The message's log time.
        log_time_ns: u64,
        /// What is wrong.
        source: CdrError,
    },
}

/// The topics a bag is read for.
#[derive(Clone, Debug)]
pub struct BagTopics {
    /// Colour images (raw; `<colour>/compressed` is the compressed transport's).
    pub colour: String,
    /// Depth images (raw; `<depth>/compressedDepth` is the compressed transport's).
    pub depth: String,
    /// Camera info.
    pub camera_info: String,
    /// The transport read when the bag has both.
    pub transport: Transport,
    /// The IMU topics, when the IMU is read: the unified one if the bag has it, else
    /// the gyroscope and accelerometer ones if it has both.
    pub imu: Option<ImuTopics>,
}

impl BagTopics {
    /// The topics of `raw` for each transport, `transport`'s first.
    fn candidates(&self, raw: &str, plugin: &str) -> [String; 2] {
        let compressed = format!("{raw}/{plugin}");
        match self.transport {
            Transport::Raw => [raw.to_owned(), compressed],
            Transport::Compressed => [compressed, raw.to_owned()],
        }
    }

    /// The topics read from a bag with `channels` (all its files' summaries): per image
    /// stream, the preferred transport's topic if the bag has it, else the other's.
    fn resolve(&self, channels: &[ChannelInfo]) -> Self {
        let pick = |candidates: [String; 2]| {
            let present = |t: &String| channels.iter().any(|c| &c.topic == t);
            match candidates.iter().position(present) {
                Some(i) => candidates[i].clone(),
                None => candidates[0].clone(),
            }
        };
        let present = |t: &String| channels.iter().any(|c| &c.topic == t);
        let imu = self.imu.as_ref().and_then(|imu| {
            if present(&imu.unified) {
                Some(ImuTopics {
                    gyro: String::new(),
                    accel: String::new(),
                    ..imu.clone()
                })
            } else if present(&imu.gyro) && present(&imu.accel) {
                Some(ImuTopics {
                    unified: String::new(),
                    ..imu.clone()
                })
            } else {
                None
            }
        });
        Self {
            colour: pick(self.candidates(&self.colour, "compressed")),
            depth: pick(self.candidates(&self.depth, "compressedDepth")),
            camera_info: self.camera_info.clone(),
            transport: self.transport,
            imu,
        }
    }
}

/// One paired frame of a bag.
#[derive(Clone, Debug)]
pub struct BagFrame {
    /// The colour image.
    pub colour: TransportImage,
    /// Its depth image.
    pub depth: TransportImage,
}

/// The `.mcap` files of a bag, in name order.
///
/// # Errors
/// [`BagError::NotABag`] / [`BagError::Io`].
pub fn bag_files(path: &Path) -> Result<Vec<PathBuf>, BagError> {
    let io = |source| BagError::Io {
        path: path.to_path_buf(),
        source,
    };
    let files = if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(io)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
            .collect();
        files.sort();
        files
    } else if path.extension().is_some_and(|e| e == "mcap") && path.is_file() {
        vec![path.to_path_buf()]
    } else {
        Vec::new()
    };
    if files.is_empty() {
        return Err(BagError::NotABag {
            path: path.to_path_buf(),
        });
    }
    Ok(files)
}

/// True when `path` looks like a ROS 2 bag (an `.mcap` file, or a folder holding one).
pub fn is_bag(path: &Path) -> bool {
    bag_files(path).is_ok()
}

/// What one message of the bag is to the reader.
enum Decoded {
    Colour(TransportImage),
    Depth(TransportImage),
    Info(Box<CameraInfo>),
    Imu(ImuTopic, Box<Imu>),
    Skipped,
}

/// Reads the paired frames of a bag in order; colour without depth is skipped with a
/// warning naming the topic and stamp, an undecodable image likewise.
pub struct BagReader {
    path: PathBuf,
    topics: BagTopics,
    files: VecDeque<PathBuf>,
    records: Option<(PathBuf, Records)>,
    pairer: Pairer<TransportImage, TransportImage>,
    camera_info: Option<CameraInfo>,
    seen: BTreeSet<String>,
    counts: [usize; 3],
    ended: bool,
    /// The IMU topics' checks and union, when the bag has them and they are read.
    imu: Option<ImuInput>,
    /// Samples read and not taken yet, and the newest stamp read.
    imu_samples: Vec<ImuSample>,
    imu_newest: Option<Stamp>,
}

/// Messages read ahead at most looking for an IMU sample past a frame (2.5 s of a
/// 400 Hz IMU): an IMU that stopped does not make the reader hold the rest of the bag.
const IMU_READ_AHEAD: usize = 1000;

impl BagReader {
    /// Opens the bag at `path`: checks that each file is complete and picks the image
    /// topics from their summaries.
    ///
    /// # Errors
    /// [`BagError::NotABag`] / [`BagError::Io`] / [`BagError::Truncated`] /
    /// [`BagError::Corrupt`].
    pub fn open(path: &Path, topics: &BagTopics, slop_s: f64) -> Result<Self, BagError> {
        let files = bag_files(path)?;
        let mut channels = Vec::new();
        for file in &files {
            if let Some(start) = summary_start(file)? {
                channels.extend(summary_channels(file, start)?);
            }
        }
        let topics = topics.resolve(&channels);
        Ok(Self {
            imu: topics.imu.clone().map(ImuInput::new),
            imu_samples: Vec::new(),
            imu_newest: None,
            path: path.to_path_buf(),
            topics,
            files: files.into(),
            records: None,
            pairer: Pairer::new(slop_s, 64),
            camera_info: None,
            seen: BTreeSet::new(),
            counts: [0; 3],
            ended: false,
        })
    }

    /// The first camera info read so far.
    pub fn camera_info(&self) -> Option<&CameraInfo> {
        self.camera_info.as_ref()
    }

    /// The colour and depth topics read (the transport found in the bag).
    pub fn image_topics(&self) -> (&str, &str) {
        (&self.topics.colour, &self.topics.depth)
    }

    /// The IMU topics read (`None`: the bag has none, or the IMU is not read).
    pub fn imu_topics(&self) -> Option<&ImuTopics> {
        self.imu.as_ref().map(ImuInput::topics)
    }

    /// Reads on until an IMU sample past `stamp` (the IMU's clock) has been read, the bag
    /// ended, or [`IMU_READ_AHEAD`] messages later; then moves the samples read into
    /// `feed`.
    ///
    /// # Errors
    /// As [`Self::next_frame`].
    pub fn imu_past(&mut self, stamp: Stamp, feed: &mut ImuFeed) -> Result<(), BagError> {
        let mut budget = IMU_READ_AHEAD;
        while self.imu.is_some()
            && !self.ended
            && budget > 0
            && self.imu_newest.is_none_or(|newest| newest <= stamp)
        {
            if !self.read_message()? {
                self.ended = true;
            }
            budget -= 1;
        }
        for sample in self.imu_samples.drain(..) {
            feed.push(sample);
        }
        Ok(())
    }

    /// The next frame, `Ok(None)` at the end.
    ///
    /// # Errors
    /// [`BagError`] for a malformed file, a topic of another type, or (at the end) a
    /// topic with no message.
    pub fn next_frame(&mut self) -> Result<Option<BagFrame>, BagError> {
        loop {
            let decided = if self.ended {
                self.pairer.flush()
            } else {
                self.pairer.decide_next()
            };
            match decided {
                Some(Paired::Pair(colour, depth)) => return Ok(Some(BagFrame { colour, depth })),
                Some(Paired::ColourWithoutDepth(stamp)) => {
                    tracing::warn!(
                        "{}: {} at {} s has no {} image within the slop; skipped",
                        self.path.display(),
                        self.topics.colour,
                        Stamp::from_nanos(stamp),
                        self.topics.depth
                    );
                    continue;
                }
                Some(Paired::NotAfter { stamp, last }) => {
                    tracing::warn!(
                        "{}: {} at {} is not after the frame before it, at {}; skipped",
                        self.path.display(),
                        self.topics.colour,
                        Stamp::from_nanos(stamp),
                        Stamp::from_nanos(last)
                    );
                    continue;
                }
                None if self.ended => {
                    self.check_topics()?;
                    return Ok(None);
                }
                None => {}
            }
            if !self.read_message()? {
                self.ended = true;
            }
        }
    }

    fn check_topics(&self) -> Result<(), BagError> {
        let wanted = [
            &self.topics.colour,
            &self.topics.depth,
            &self.topics.camera_info,
        ];
        for (topic, count) in wanted.into_iter().zip(self.counts) {
            if count == 0 {
                return Err(self.missing(topic));
            }
        }
        Ok(())
    }

    fn missing(&self, topic: &str) -> BagError {
        BagError::MissingTopic {
            path: self.path.clone(),
            topic: topic.to_owned(),
            found: self.seen.iter().cloned().collect::<Vec<_>>().join(", "),
        }
    }

    /// Reads one message; false at the end of the last file.
    fn read_message(&mut self) -> Result<bool, BagError> {
        loop {
            if self.records.is_none() {
                let Some(file) = self.files.pop_front() else {
                    return Ok(false);
                };
                let records = Records::open(&file, None)?;
                self.records = Some((file, records));
            }
            let Some((file, records)) = self.records.as_mut() else {
                continue;
            };
            let (topics, seen) = (&self.topics, &mut self.seen);
            let decoded = records.next(|message| {
                if !seen.contains(&message.channel.topic) {
                    seen.insert(message.channel.topic.clone());
                }
                decode(&message, topics, file)
            })?;
            let decoded = match decoded {
                None => {
                    self.records = None;
                    continue;
                }
                Some(decoded) => decoded?,
            };
            let stamp = |image: &TransportImage| image.header().stamp.nanos();
            match decoded {
                Decoded::Colour(image) => {
                    self.counts[0] += 1;
                    self.pairer.push_colour(stamp(&image), image);
                }
                Decoded::Depth(image) => {
                    self.counts[1] += 1;
                    self.pairer.push_depth(stamp(&image), image);
                }
                Decoded::Info(info) => {
                    self.counts[2] += 1;
                    self.camera_info.get_or_insert(*info);
                }
                Decoded::Imu(which, message) => {
                    if let Some(imu) = self.imu.as_mut() {
                        let before = self.imu_samples.len();
                        imu.push(which, &message, &mut self.imu_samples);
                        if self.imu_samples.len() > before {
                            self.imu_newest = self.imu_samples.last().map(|s| s.stamp);
                        }
                    }
                }
                Decoded::Skipped => continue,
            }
            return Ok(true);
        }
    }
}

/// Decodes a message of the topics read (by its schema); other topics and undecodable
/// images (with a warning naming topic and log time) are skipped.
fn decode(
    message: &RecordMessage<'_>,
    topics: &BagTopics,
    file: &Path,
) -> Result<Decoded, BagError> {
    let topic = message.channel.topic.as_str();
    let schema = message.channel.schema.as_str();
    let payload = |source| BagError::Payload {
        path: file.to_path_buf(),
        topic: topic.to_owned(),
        log_time_ns: message.log_time,
        source,
    };
    let wrong = |expected| BagError::Schema {
        path: file.to_path_buf(),
        topic: topic.to_owned(),
        schema: schema.to_owned(),
        expected,
    };
    if topic == topics.camera_info {
        if !matches!(
            schema,
            "" | "sensor_msgs/msg/CameraInfo" | "sensor_msgs/CameraInfo"
        ) {
            return Err(wrong("sensor_msgs/msg/CameraInfo"));
        }
        let info = cdr::decode(message.data, "sensor_msgs/CameraInfo").map_err(payload)?;
        return Ok(Decoded::Info(Box::new(info)));
    }
    if let Some(which) = topics.imu.as_ref().and_then(|imu| imu.which(topic)) {
        if !matches!(schema, "" | "sensor_msgs/msg/Imu" | "sensor_msgs/Imu") {
            return Err(wrong("sensor_msgs/msg/Imu"));
        }
        return Ok(match cdr::decode::<Imu>(message.data, "sensor_msgs/Imu") {
            Ok(imu) => Decoded::Imu(which, Box::new(imu)),
            Err(e) => {
                tracing::warn!(
                    "{}: {topic} logged at {:.9} s: {e}; message skipped",
                    file.display(),
                    message.log_time as f64 * 1e-9
                );
                Decoded::Skipped
            }
        });
    }
    let colour = topic == topics.colour;
    if !colour && topic != topics.depth {
        return Ok(Decoded::Skipped);
    }
    let image = match schema {
        "" | "sensor_msgs/msg/Image" | "sensor_msgs/Image" => {
            cdr::decode::<Image>(message.data, "sensor_msgs/Image").map(TransportImage::Raw)
        }
        "sensor_msgs/msg/CompressedImage" | "sensor_msgs/CompressedImage" => {
            cdr::decode::<CompressedImage>(message.data, "sensor_msgs/CompressedImage")
                .map(TransportImage::Compressed)
        }
        _ => {
            return Err(wrong(
                "sensor_msgs/msg/Image or sensor_msgs/msg/CompressedImage",
            ));
        }
    };
    match image {
        Ok(image) if colour => Ok(Decoded::Colour(image)),
        Ok(image) => Ok(Decoded::Depth(image)),
        Err(e) => {
            tracing::warn!(
                "{}: {topic} logged at {:.9} s: {e}; message skipped",
                file.display(),
                message.log_time as f64 * 1e-9
            );
            Ok(Decoded::Skipped)
        }
    }
}

/// The colour stamps of the frames of a bag and its camera info: a full pass
/// over the bag, for the supervisor (frame count, timestamps of the trajectory).
///
/// # Errors
/// [`BagError`] as [`BagReader::next_frame`], or no camera info.
pub fn scan(
    path: &Path,
    topics: &BagTopics,
    slop_s: f64,
) -> Result<(Vec<Stamp>, CameraInfo), BagError> {
    let mut reader = BagReader::open(path, topics, slop_s)?;
    let mut stamps = Vec::new();
    while let Some(frame) = reader.next_frame()? {
        stamps.push(frame.colour.header().stamp.into());
    }
    match reader.camera_info.take() {
        Some(info) => Ok((stamps, info)),
        None => Err(reader.missing(&topics.camera_info)),
    }
}
