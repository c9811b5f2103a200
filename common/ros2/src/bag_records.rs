//! The records of one `.mcap` file, read with lengths that cannot be trusted: every
//! length is checked against the bytes left in the file and a limit for one record
//! before anything is allocated, chunks are decompressed (zstd, lz4) and their CRC
//! checked, and every error names the file and the byte offset reached. Only the records
//! a bag reader needs are parsed (schema, channel, message, and the footer that says the
//! file is complete), by hand, so that no length field reaches an allocation unchecked.

use crate::bag::BagError;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// The largest record (or decompressed chunk record) read: far above any camera image
/// (a 4K `rgba8` frame is 33 MB), far below what would exhaust a robot's memory.
pub const MAX_RECORD_BYTES: usize = 256 << 20;

/// `0x89 MCAP0 \r\n`, at both ends of a complete file.
const MAGIC: [u8; 8] = [0x89, b'M', b'C', b'A', b'P', b'0', b'\r', b'\n'];
/// Footer record: opcode, length 20, summary start, summary offset start, summary CRC.
const FOOTER_BYTES: usize = 1 + 8 + 20;

const OP_SCHEMA: u8 = 0x03;
const OP_CHANNEL: u8 = 0x04;
const OP_MESSAGE: u8 = 0x05;
const OP_FOOTER: u8 = 0x02;
const OP_DATA_END: u8 = 0x0F;

/// A channel of the file: its topic and the name of its schema (`pkg/msg/Type`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChannelInfo {
    /// The topic.
    pub topic: String,
    /// The schema name, empty for a channel without schema.
    pub schema: String,
}

/// One message of the file, borrowed from the reader's buffer.
pub struct RecordMessage<'a> {
    /// Its channel.
    pub channel: &'a ChannelInfo,
    /// Its log time, nanoseconds.
    pub log_time: u64,
    /// The serialised message.
    pub data: &'a [u8],
}

/// The records of one file, from the start of its data section or of its summary.
pub struct Records {
    path: PathBuf,
    file: BufReader<File>,
    size: u64,
    position: u64,
    reader: LinearReader,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, ChannelInfo>,
    last: Option<(u16, u64)>,
    done: bool,
}

/// Where a complete file's summary section starts (None: it has none).
///
/// # Errors
/// [`BagError::Io`], [`BagError::Truncated`] when the file does not begin and end with
/// the MCAP magic and footer (a recording that did not finish), [`BagError::Corrupt`]
/// when the footer points outside the file.
pub fn summary_start(path: &Path) -> Result<Option<u64>, BagError> {
    let mut file = File::open(path).map_err(|e| io(path, e))?;
    let size = file.metadata().map_err(|e| io(path, e))?.len();
    let tail = (FOOTER_BYTES + MAGIC.len()) as u64;
    let truncated = |reason: String| BagError::Truncated {
        path: path.to_path_buf(),
        size,
        reason,
    };
    let mut head = [0u8; 8];
    if size < MAGIC.len() as u64 + tail || file.read_exact(&mut head).is_err() || head != MAGIC {
        return Err(truncated("not an MCAP file (no magic at its start)".into()));
    }
    let mut end = [0u8; FOOTER_BYTES + MAGIC.len()];
    file.seek(SeekFrom::Start(size - tail))
        .and_then(|_| file.read_exact(&mut end))
        .map_err(|e| io(path, e))?;
    if end[FOOTER_BYTES..] != MAGIC || end[0] != OP_FOOTER || u64_at(&end, 1) != Some(20) {
        return Err(truncated(
            "no MCAP footer at its end (a recording that did not finish)".into(),
        ));
    }
    let start = u64_at(&end, 9).unwrap_or(0);
    if start == 0 {
        return Ok(None);
    }
    if start < MAGIC.len() as u64 || start > size - tail {
        return Err(BagError::Corrupt {
            path: path.to_path_buf(),
            offset: size - tail,
            reason: format!("the footer puts the summary at byte {start}, outside the file"),
        });
    }
    Ok(Some(start))
}

/// The channels of a file's summary section.
///
/// # Errors
/// [`BagError`] as [`Records::next`].
pub fn summary_channels(path: &Path, start: u64) -> Result<Vec<ChannelInfo>, BagError> {
    let mut records = Records::open(path, Some(start))?;
    while records.next(|_| ())?.is_some() {}
    Ok(records.channels.into_values().collect())
}

impl Records {
    /// Opens `path` at its data section (`summary: None`) or at the summary section
    /// starting at byte `summary`.
    ///
    /// # Errors
    /// [`BagError::Io`].
    pub fn open(path: &Path, summary: Option<u64>) -> Result<Self, BagError> {
        let mut file = File::open(path).map_err(|e| io(path, e))?;
        let size = file.metadata().map_err(|e| io(path, e))?.len();
        let position = match summary {
            Some(start) => file.seek(SeekFrom::Start(start)).map_err(|e| io(path, e))?,
            None => 0,
        };
        let options = LinearReaderOptions::default()
            .with_skip_start_magic(summary.is_some())
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(MAX_RECORD_BYTES);
        Ok(Self {
            path: path.to_path_buf(),
            file: BufReader::with_capacity(1 << 20, file),
            size,
            position,
            reader: LinearReader::new_with_options(options),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            last: None,
            done: false,
        })
    }

    /// Hands the next message to `visit` and returns what it returns; `Ok(None)` at the
    /// end of the data section (or of the file, for the summary).
    ///
    /// # Errors
    /// [`BagError::Corrupt`] naming the byte offset reached (and the last message read),
    /// [`BagError::Io`].
    pub fn next<T>(
        &mut self,
        visit: impl FnOnce(RecordMessage<'_>) -> T,
    ) -> Result<Option<T>, BagError> {
        if self.done {
            return Ok(None);
        }
        loop {
            let event = match self.reader.next_event() {
                None => {
                    self.done = true;
                    return Ok(None);
                }
                Some(Err(e)) => {
                    self.done = true;
                    return Err(self.corrupt(e.to_string()));
                }
                Some(Ok(event)) => event,
            };
            let (opcode, data) = match event {
                LinearReadEvent::ReadRequest(need) => {
                    let left = self.size - self.position;
                    if need as u64 > left && left > 0 {
                        self.done = true;
                        return Err(self.corrupt(format!(
                            "a record needs {need} more bytes, the file has {left} left"
                        )));
                    }
                    let buffer = self.reader.insert(need.min(left as usize));
                    let read = read_full(&mut self.file, buffer).map_err(|e| io(&self.path, e))?;
                    self.reader.notify_read(read);
                    self.position += read as u64;
                    continue;
                }
                LinearReadEvent::Record { opcode, data } => (opcode, data),
            };
            match opcode {
                OP_SCHEMA => {
                    let Some((id, name)) = parse_schema(data) else {
                        return Err(self.corrupt_now(BAD_SCHEMA));
                    };
                    self.schemas.insert(id, name);
                }
                OP_CHANNEL => {
                    let Some((id, schema_id, topic)) = parse_channel(data) else {
                        return Err(self.corrupt_now(BAD_CHANNEL));
                    };
                    let schema = match schema_id {
                        0 => String::new(),
                        schema_id => match self.schemas.get(&schema_id) {
                            Some(name) => name.clone(),
                            None => {
                                return Err(self.corrupt_now(&format!(
                                    "channel {topic} names schema {schema_id}, which no \
                                     schema record declared before it"
                                )));
                            }
                        },
                    };
                    self.channels.insert(id, ChannelInfo { topic, schema });
                }
                OP_MESSAGE => {
                    let Some((channel_id, log_time, payload)) = parse_message(data) else {
                        return Err(self.corrupt_now("a message record is cut short"));
                    };
                    let Some(channel) = self.channels.get(&channel_id) else {
                        return Err(self.corrupt_now(&format!(
                            "a message on channel {channel_id}, which no channel record declared"
                        )));
                    };
                    self.last = Some((channel_id, log_time));
                    return Ok(Some(visit(RecordMessage {
                        channel,
                        log_time,
                        data: payload,
                    })));
                }
                OP_DATA_END => {
                    self.done = true;
                    return Ok(None);
                }
                _ => {}
            }
        }
    }

    fn corrupt_now(&mut self, reason: &str) -> BagError {
        self.done = true;
        self.corrupt(reason.to_owned())
    }

    fn corrupt(&self, reason: String) -> BagError {
        let after = self
            .last
            .and_then(|(id, time)| Some((self.channels.get(&id)?, time)))
            .map(|(c, time)| {
                format!(
                    " (after the message on {} logged at {:.9} s)",
                    c.topic,
                    time as f64 * 1e-9
                )
            })
            .unwrap_or_default();
        BagError::Corrupt {
            path: self.path.clone(),
            offset: self.position,
            reason: format!("{reason}{after}"),
        }
    }
}

const BAD_SCHEMA: &str = "a schema record is cut short or its name is not UTF-8";
const BAD_CHANNEL: &str = "a channel record is cut short or its topic is not UTF-8";

fn io(path: &Path, source: std::io::Error) -> BagError {
    BagError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads until `buffer` is full or the file ends; the bytes read.
fn read_full(file: &mut impl Read, buffer: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match file.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// Little-endian fields of a record body, each read checked against its end.
struct Fields<'a>(&'a [u8]);

impl<'a> Fields<'a> {
    fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.0.len() {
            return None;
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Some(head)
    }

    fn u16(&mut self) -> Option<u16> {
        Some(u16::from_le_bytes(self.bytes(2)?.try_into().ok()?))
    }

    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.bytes(4)?.try_into().ok()?))
    }

    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.bytes(8)?.try_into().ok()?))
    }

    fn string(&mut self) -> Option<String> {
        let len = self.u32()? as usize;
        String::from_utf8(self.bytes(len)?.to_vec()).ok()
    }
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Fields(bytes.get(at..)?).u64()
}

/// Schema: id, name, (encoding, data: not needed).
fn parse_schema(data: &[u8]) -> Option<(u16, String)> {
    let mut f = Fields(data);
    Some((f.u16()?, f.string()?))
}

/// Channel: id, schema id, topic, (encoding, metadata: not needed).
fn parse_channel(data: &[u8]) -> Option<(u16, u16, String)> {
    let mut f = Fields(data);
    Some((f.u16()?, f.u16()?, f.string()?))
}

/// Message: channel id, sequence, log time, publish time, then the payload.
fn parse_message(data: &[u8]) -> Option<(u16, u64, &[u8])> {
    let mut f = Fields(data);
    let channel = f.u16()?;
    f.u32()?;
    let log_time = f.u64()?;
    f.u64()?;
    Some((channel, log_time, f.0))
}
