//! Writing ROS 2 messages into an MCAP file with the `ros2` profile (`cdr` messages,
//! `ros2msg` schemas) that Foxglove, `ros2 bag` and `rosbags` read, in chunks
//! compressed as `ros2 bag record` does (zstd by default). The file is written under a
//! temporary name and renamed once its summary and footer are written: a run that fails
//! or is killed half-way leaves no file that reads as a complete bag.

use crate::bag::BagError;
use crate::cdr;
use crate::schema::MessageSchema;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Chunk compression of a written bag.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Compression {
    /// Uncompressed chunks.
    None,
    /// lz4 frames: fast, larger.
    Lz4,
    /// zstd (level 3), what `ros2 bag record -s mcap` writes.
    #[default]
    Zstd,
}

impl std::str::FromStr for Compression {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "none" => Ok(Self::None),
            "lz4" => Ok(Self::Lz4),
            "zstd" => Ok(Self::Zstd),
            other => Err(format!(
                "{other:?} is not an MCAP chunk compression (none, lz4, zstd)"
            )),
        }
    }
}

/// Writes ROS 2 messages into an MCAP file (`ros2` profile).
pub struct BagWriter {
    path: PathBuf,
    partial: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: BTreeMap<String, u16>,
    schemas: BTreeMap<&'static str, u16>,
    scratch: Vec<u8>,
    sequence: u32,
    finished: bool,
}

impl BagWriter {
    /// Starts writing `path` (replaced when [`BagWriter::finish`] succeeds) with chunks
    /// compressed by `compression`.
    ///
    /// # Errors
    /// [`BagError::Io`] / [`BagError::Mcap`].
    pub fn create(path: &Path, compression: Compression) -> Result<Self, BagError> {
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(".partial");
        let partial = path.with_file_name(name);
        let file = File::create(&partial).map_err(|source| BagError::Io {
            path: partial.clone(),
            source,
        })?;
        let compression = match compression {
            Compression::None => None,
            Compression::Lz4 => Some(mcap::Compression::Lz4),
            Compression::Zstd => Some(mcap::Compression::Zstd),
        };
        // One thread: the recorder runs beside the pipeline's stages.
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library("gfsvo")
            .compression(compression)
            .compression_threads(0)
            .create(BufWriter::new(file))
            .map_err(|e| mcap_error(&partial, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            writer,
            channels: BTreeMap::new(),
            schemas: BTreeMap::new(),
            scratch: Vec::new(),
            sequence: 0,
            finished: false,
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
            .map_err(|e| mcap_error(&self.partial, e))
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
                    .map_err(|e| mcap_error(&self.partial, e))?;
                self.schemas.insert(schema.name, id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(schema_id, topic, "cdr", &BTreeMap::new())
            .map_err(|e| mcap_error(&self.partial, e))?;
        self.channels.insert(topic.to_owned(), id);
        Ok(id)
    }

    /// Writes the summary and footer, closes the file and gives it its name.
    ///
    /// # Errors
    /// [`BagError::Mcap`] / [`BagError::Io`].
    pub fn finish(mut self) -> Result<(), BagError> {
        self.writer
            .finish()
            .map_err(|e| mcap_error(&self.partial, e))?;
        std::fs::rename(&self.partial, &self.path).map_err(|source| BagError::Io {
            path: self.path.clone(),
            source,
        })?;
        self.finished = true;
        Ok(())
    }
}

impl Drop for BagWriter {
    /// An unfinished bag goes: the MCAP writer's own drop would complete it with a
    /// summary, and a bag cut short must not read as whole.
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

fn mcap_error(path: &Path, e: mcap::McapError) -> BagError {
    BagError::Mcap {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}
