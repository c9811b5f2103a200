//! Frame and variable-size messages on `[u8]` topics: the glue between the payload
//! layouts ([`crate::frame`], [`crate::codec`]) and the ports ([`crate::topic`]).

use iceoryx2::service::Service;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::codec::{decode_message, encode_message};
use crate::error::IpcError;
use crate::frame::{FrameError, FrameImages, FrameLayout, FrameView, FrameViewMut};
use crate::header::MsgHeader;
use crate::topic::{TopicPublisher, TopicSample, TopicSampleMut, TopicSubscriber};

impl<S: Service> TopicPublisher<S, u8> {
    /// Loans a frame sample laid out as `layout` with `header`; fill it in place through
    /// [`frame_view_mut`] and hand it to [`TopicPublisher::send`].
    ///
    /// # Errors
    /// [`IpcError::Loan`] when no sample is free.
    pub fn loan_frame(
        &self,
        header: &MsgHeader,
        layout: &FrameLayout,
    ) -> Result<TopicSampleMut<S, u8>, IpcError> {
        self.loan(header, layout.byte_len())
    }

    /// Publishes `images` as one frame (one copy, into shared memory); returns how many
    /// subscribers it reached.
    ///
    /// # Errors
    /// [`IpcError::Frame`] when the images differ in size, [`IpcError::Loan`] /
    /// [`IpcError::Send`] from the transport.
    pub fn publish_frame(
        &self,
        header: &MsgHeader,
        images: &FrameImages<'_>,
    ) -> Result<usize, IpcError> {
        let frame_err = |source| IpcError::Frame {
            topic: self.topic().to_string(),
            source,
        };
        let layout = images.layout().map_err(frame_err)?;
        let mut sample = self.loan_frame(header, &layout)?;
        FrameViewMut::new(&layout, sample.payload_mut())
            .and_then(|mut planes| planes.copy_from(images))
            .map_err(frame_err)?;
        self.send(sample)
    }

    /// Encodes `value` with bincode (into `scratch`, reused between calls) and publishes
    /// it; returns how many subscribers it reached.
    ///
    /// # Errors
    /// [`IpcError::Encode`] when the value cannot be encoded or is over the size limit,
    /// [`IpcError::Loan`] / [`IpcError::Send`] from the transport.
    pub fn publish_encoded<T: Serialize>(
        &self,
        header: &MsgHeader,
        value: &T,
        scratch: &mut Vec<u8>,
    ) -> Result<usize, IpcError> {
        encode_message(value, scratch).map_err(|source| IpcError::Encode {
            topic: self.topic().to_string(),
            source,
        })?;
        self.publish_slice(header, scratch)
    }
}

/// The writable planes of a loaned frame sample (see [`TopicPublisher::loan_frame`]).
///
/// # Errors
/// [`FrameError`] when the sample is smaller than `layout` (it was loaned for another).
pub fn frame_view_mut<'a, S: Service>(
    sample: &'a mut TopicSampleMut<S, u8>,
    layout: &FrameLayout,
) -> Result<FrameViewMut<'a>, FrameError> {
    FrameViewMut::new(layout, sample.payload_mut())
}

/// The images of a received frame sample, borrowed from shared memory.
///
/// # Errors
/// [`FrameError`] for a malformed payload (log and drop the sample).
pub fn frame_view<S: Service>(sample: &TopicSample<S, u8>) -> Result<FrameView<'_>, FrameError> {
    FrameView::parse(sample.payload())
}

impl<S: Service> TopicSubscriber<S, u8> {
    /// Receives the next well-formed bincode message of type `T` (at most `max_bytes`),
    /// with its header. Malformed, truncated or oversized messages are logged with
    /// `tracing::warn!` and dropped; `Ok(None)` when the queue holds no valid message.
    ///
    /// # Errors
    /// [`IpcError::Receive`] when the transport fails (not for bad messages).
    pub fn receive_decoded<T: DeserializeOwned>(
        &self,
        max_bytes: usize,
    ) -> Result<Option<(MsgHeader, T)>, IpcError> {
        while let Some(sample) = self.receive()? {
            let header = *sample.user_header();
            match decode_message(sample.payload(), max_bytes) {
                Ok(value) => return Ok(Some((header, value))),
                Err(e) => tracing::warn!(
                    topic = self.topic(),
                    frame = header.frame_id,
                    "dropping malformed message: {e}"
                ),
            }
        }
        Ok(None)
    }
}
