//! ROS 2 bags in MCAP: reading the colour / depth / camera-info topics of a bag (a bag
//! folder with `metadata.yaml` and `.mcap` files, or a bare `.mcap`) as a sequence of
//! paired frames, and writing messages with the `ros2` profile (`cdr` messages,
//! `ros2msg` schemas) that Foxglove, `ros2 bag` and `rosbags` read.

use crate::cdr::{self, CdrError};
use crate::msg::{CameraInfo, Image};
use crate::pairing::{Paired, Pairer};
use crate::schema::MessageSchema;
use gfs_core::stamp::Stamp;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fs::File;
use std::io::{BufReader, BufWriter};
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
    /// The MCAP container is malformed (or uses a compression this build has not).
    #[error("{path}: {message}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What the MCAP reader said.
        message: String,
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
    /// Colour images.
    pub colour: String,
    /// Depth images.
    pub depth: String,
    /// Camera info.
    pub camera_info: String,
}

/// One paired frame of a bag.
#[derive(Clone, Debug)]
pub struct BagFrame {
    /// The colour image.
    pub colour: Image,
    /// Its depth image.
    pub depth: Image,
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

/// Reads the paired frames of a bag in order; colour without depth is skipped with a
/// warning naming the topic and stamp, an undecodable message likewise.
pub struct BagReader {
    path: PathBuf,
    topics: BagTopics,
    files: VecDeque<PathBuf>,
    messages: Option<(PathBuf, mcap::io::MessageReader<BufReader<File>>)>,
    pairer: Pairer<Image, Image>,
    camera_info: Option<CameraInfo>,
    seen: BTreeSet<String>,
    counts: [usize; 3],
    ended: bool,
}

impl BagReader {
    /// Opens the bag at `path`.
    ///
    /// # Errors
    /// [`BagError::NotABag`] / [`BagError::Io`].
    pub fn open(path: &Path, topics: &BagTopics, slop_s: f64) -> Result<Self, BagError> {
        Ok(Self {
            path: path.to_path_buf(),
            topics: topics.clone(),
            files: bag_files(path)?.into(),
            messages: None,
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

    /// The next frame, `Ok(None)` at the end.
    ///
    /// # Errors
    /// [`BagError`] for a malformed file, or (at the end) a topic with no message.
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
                        "{}: {} at {:.6} s has no {} image within the slop; skipped",
                        self.path.display(),
                        self.topics.colour,
                        stamp as f64 * 1e-9,
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
                return Err(BagError::MissingTopic {
                    path: self.path.clone(),
                    topic: topic.clone(),
                    found: self.seen.iter().cloned().collect::<Vec<_>>().join(", "),
                });
            }
        }
        Ok(())
    }

    /// Reads one message; false at the end of the last file.
    fn read_message(&mut self) -> Result<bool, BagError> {
        loop {
            if self.messages.is_none() {
                let Some(file) = self.files.pop_front() else {
                    return Ok(false);
                };
                let reader = File::open(&file).map_err(|source| BagError::Io {
                    path: file.clone(),
                    source,
                })?;
                let stream =
                    mcap::io::MessageReader::new(BufReader::with_capacity(1 << 20, reader));
                self.messages = Some((file, stream));
            }
            let Some((file, stream)) = self.messages.as_mut() else {
                continue;
            };
            let message = match stream.next() {
                None => {
                    self.messages = None;
                    continue;
                }
                Some(Err(e)) => {
                    return Err(BagError::Mcap {
                        path: file.clone(),
                        message: e.to_string(),
                    });
                }
                Some(Ok(m)) => m,
            };
            let topic = message.channel.topic.as_str();
            let slot = if topic == self.topics.colour {
                0
            } else if topic == self.topics.depth {
                1
            } else if topic == self.topics.camera_info {
                2
            } else {
                if !self.seen.contains(topic) {
                    self.seen.insert(topic.to_owned());
                }
                return Ok(true);
            };
            self.seen.insert(topic.to_owned());
            let payload = |e| BagError::Payload {
                path: file.clone(),
                topic: topic.to_owned(),
                log_time_ns: message.log_time,
                source: e,
            };
            match slot {
                2 => {
                    let info: CameraInfo =
                        cdr::decode(&message.data, "sensor_msgs/CameraInfo").map_err(payload)?;
                    self.camera_info.get_or_insert(info);
                }
                _ => match cdr::decode::<Image>(&message.data, "sensor_msgs/Image") {
                    Ok(image) => {
                        let stamp = image.header.stamp.nanos();
                        if slot == 0 {
                            self.pairer.push_colour(stamp, image);
                        } else {
                            self.pairer.push_depth(stamp, image);
                        }
                    }
                    Err(e) => {
                        tracing::warn!("{}: {topic}: {e}; message skipped", file.display());
                        continue;
                    }
                },
            }
            self.counts[slot] += 1;
            return Ok(true);
        }
    }
}

/// The colour stamps (seconds) of the frames of a bag and its camera info: a full pass
/// over the bag, for the supervisor (frame count, timestamps of the trajectory).
///
/// # Errors
/// [`BagError`] as [`BagReader::next_frame`], or no camera info.
pub fn scan(
    path: &Path,
    topics: &BagTopics,
    slop_s: f64,
) -> Result<(Vec<f64>, CameraInfo), BagError> {
    let mut reader = BagReader::open(path, topics, slop_s)?;
    let mut stamps = Vec::new();
    while let Some(frame) = reader.next_frame()? {
        stamps.push(frame.colour.header.stamp.secs());
    }
    let info = reader.camera_info.ok_or_else(|| BagError::MissingTopic {
        path: path.to_path_buf(),
        topic: topics.camera_info.clone(),
        found: reader.seen.iter().cloned().collect::<Vec<_>>().join(", "),
    })?;
    Ok((stamps, info))
}

/// Writes ROS 2 messages into an MCAP file (`ros2` profile).
pub struct BagWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: BTreeMap<String, u16>,
    schemas: BTreeMap<&'static str, u16>,
    scratch: Vec<u8>,
    sequence: u32,
}

impl BagWriter {
    /// Creates `path` (overwritten).
    ///
    /// # Errors
    /// [`BagError::Io`] / [`BagError::Mcap`].
    pub fn create(path: &Path) -> Result<Self, BagError> {
        let file = File::create(path).map_err(|source| BagError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library("gfsvo")
            .compression(None)
            .create(BufWriter::new(file))
            .map_err(|e| mcap_error(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            channels: BTreeMap::new(),
            schemas: BTreeMap::new(),
            scratch: Vec::new(),
            sequence: 0,
        })
    }

    /// Writes `message` of type `schema` on `topic`, logged at `time_ns`.
    ///
    /// # Errors
    /// [`BagError::Mcap`], or [`BagError::Payload`] when it cannot be encoded.
    pub fn write<T: Serialize>(
        &mut self,
        topic: &str,
        schema: &MessageSchema,
        time_ns: u64,
        message: &T,
    ) -> Result<(), BagError> {
        let channel = self.channel(topic, schema)?;
        cdr::encode_into(message, schema.name, &mut self.scratch).map_err(|source| {
            BagError::Payload {
                path: self.path.clone(),
                topic: topic.to_owned(),
                log_time_ns: time_ns,
                source,
            }
        })?;
        self.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        self.writer
            .write_to_known_channel(&header, &self.scratch)
            .map_err(|e| mcap_error(&self.path, e))
    }

    fn channel(&mut self, topic: &str, schema: &MessageSchema) -> Result<u16, BagError> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let schema_id = match self.schemas.get(schema.name) {
            Some(&id) => id,
            None => {
                let id = self
                    .writer
                    .add_schema(schema.name, "ros2msg", schema.text().as_bytes())
                    .map_err(|e| mcap_error(&self.path, e))?;
                self.schemas.insert(schema.name, id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(schema_id, topic, "cdr", &BTreeMap::new())
            .map_err(|e| mcap_error(&self.path, e))?;
        self.channels.insert(topic.to_owned(), id);
        Ok(id)
    }

    /// Writes the summary and closes the file.
    ///
    /// # Errors
    /// [`BagError::Mcap`].
    pub fn finish(mut self) -> Result<(), BagError> {
        self.writer
            .finish()
            .map_err(|e| mcap_error(&self.path, e))?;
        Ok(())
    }
}

fn mcap_error(path: &Path, e: mcap::McapError) -> BagError {
    BagError::Mcap {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}
