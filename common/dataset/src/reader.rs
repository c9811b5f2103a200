//! The read-ahead frame iterator: a thread decodes frames into a bounded channel.

use crate::decode::{Frame, FrameDecoder};
use crate::error::DatasetError;
use crate::lists::Entry;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

type Item = Result<Frame, DatasetError>;

/// Iterator over decoded frames, made by [`crate::Sequence::frames`].
///
/// A thread decodes up to `ahead` frames before they are asked for. Dropping the reader
/// stops and joins that thread. Frames handed back with [`FrameReader::recycle`] lend
/// their buffers to the frames decoded next, so that a steady loop allocates nothing.
pub struct FrameReader {
    source: Source,
    next: usize,
    total: usize,
}

enum Source {
    Thread {
        receiver: Option<Receiver<Item>>,
        recycle: Option<Sender<Frame>>,
        stop: Arc<AtomicBool>,
        handle: Option<JoinHandle<()>>,
    },
    /// Used only if the OS refuses a thread: decode on the caller's thread instead.
    Inline {
        decoder: Box<FrameDecoder>,
        entries: Arc<[Entry]>,
        spare: Option<Frame>,
    },
}

impl FrameReader {
    pub(crate) fn spawn(
        decoder: FrameDecoder,
        entries: Arc<[Entry]>,
        range: std::ops::Range<usize>,
        ahead: usize,
    ) -> Self {
        let (start, total) = (range.start.min(range.end), range.end);
        let (tx, rx) = std::sync::mpsc::sync_channel(ahead.max(1));
        let (recycle_tx, recycle_rx) = std::sync::mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let thread_stop = Arc::clone(&stop);
        let thread_entries = Arc::clone(&entries);
        let fallback = FrameDecoder::clone_empty(&decoder);
        let spawned = std::thread::Builder::new()
            .name("gfs-frame-reader".to_owned())
            .spawn(move || {
                decode_loop(
                    decoder,
                    &thread_entries,
                    start..total,
                    &tx,
                    &recycle_rx,
                    &thread_stop,
                )
            });
        let source = match spawned {
            Ok(handle) => Source::Thread {
                receiver: Some(rx),
                recycle: Some(recycle_tx),
                stop,
                handle: Some(handle),
            },
            Err(_) => Source::Inline {
                decoder: Box::new(fallback),
                entries,
                spare: None,
            },
        };
        Self {
            source,
            next: start,
            total,
        }
    }

    /// Hands a frame the caller is done with back to the reader, whose thread decodes a
    /// later frame into its buffers instead of allocating new ones.
    pub fn recycle(&mut self, frame: Frame) {
        match &mut self.source {
            Source::Thread { recycle, .. } => {
                if let Some(tx) = recycle {
                    // The thread may have finished; the frame is then simply dropped.
                    let _ = tx.send(frame);
                }
            }
            Source::Inline { spare, .. } => *spare = Some(frame),
        }
    }
}

fn decode_loop(
    mut decoder: FrameDecoder,
    entries: &[Entry],
    range: std::ops::Range<usize>,
    tx: &SyncSender<Item>,
    recycled: &Receiver<Frame>,
    stop: &AtomicBool,
) {
    for (index, entry) in entries.iter().enumerate().take(range.end).skip(range.start) {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        let reuse = recycled.try_recv().ok();
        if tx.send(decoder.decode(index, entry, reuse)).is_err() {
            // The reader was dropped.
            return;
        }
    }
}

impl Iterator for FrameReader {
    type Item = Item;

    fn next(&mut self) -> Option<Item> {
        if self.next >= self.total {
            return None;
        }
        let index = self.next;
        self.next += 1;
        match &mut self.source {
            Source::Thread { receiver, .. } => {
                let received = receiver.as_ref().map(Receiver::recv);
                match received {
                    Some(Ok(item)) => Some(item),
                    _ => {
                        // The thread ended early: it panicked. Report once, then stop.
                        self.next = self.total;
                        Some(Err(DatasetError::ReaderStopped { index }))
                    }
                }
            }
            Source::Inline {
                decoder,
                entries,
                spare,
            } => Some(decoder.decode(index, &entries[index], spare.take())),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.total.saturating_sub(self.next);
        (left, Some(left))
    }
}

impl ExactSizeIterator for FrameReader {}

impl Drop for FrameReader {
    fn drop(&mut self) {
        if let Source::Thread {
            receiver,
            recycle,
            stop,
            handle,
        } = &mut self.source
        {
            stop.store(true, Ordering::Relaxed);
            // Dropping the receiver unblocks a thread waiting to send.
            drop(receiver.take());
            drop(recycle.take());
            if let Some(handle) = handle.take() {
                // A panic of the thread was already reported as `ReaderStopped`.
                let _ = handle.join();
            }
        }
    }
}
