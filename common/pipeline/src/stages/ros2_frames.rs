//! ROS 2 image pairs into the frame topic: what the bag player and the live ROS 2 stage
//! (`gfsvo-ros2`) share. The pair is converted straight into the loaned shared-memory
//! sample (no intermediate image).

use super::context::StageError;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_ipc::{FrameLayout, MsgHeader, Service, Stage, TopicPublisher};
use gfs_ros2::image::{FrameConverter, ImageError, Received};

/// Converts a colour + depth pair and publishes it as frame `id` stamped `stamp`.
/// A pair that cannot be converted is not published.
///
/// # Errors
/// `Ok(Err(ImageError))` for a bad pair (the caller warns and goes on);
/// [`StageError`] when the topic fails.
pub fn publish_pair<S: Service>(
    publisher: &TopicPublisher<S, u8>,
    layout: &FrameLayout,
    converter: &mut FrameConverter,
    id: u64,
    colour: Received<'_>,
    depth: Received<'_>,
) -> Result<Result<(), ImageError>, StageError> {
    if let Err(e) = converter.check(colour, depth) {
        return Ok(Err(e));
    }
    let stamp = colour.image.header.stamp.into();
    let mut header = MsgHeader::new(FrameId(id), stamp);
    header.mark_received(Stage::Source);
    header.mark_started(Stage::Source);
    let mut sample = publisher.loan_frame(&header, layout)?;
    let planes = gfs_ipc::frame_view_mut(&mut sample, layout).map_err(|e| setup(e.to_string()))?;
    if let Err(e) = converter.convert(colour, depth, planes.gray, planes.depth) {
        return Ok(Err(e));
    }
    sample.user_header_mut().mark_finished(Stage::Source);
    publisher.send(sample)?;
    Ok(Ok(()))
}

/// Publishes frame `id` with zero gray and no depth (a bag pair that could not be
/// converted: the frame keeps its place, and the tracker predicts its pose).
///
/// # Errors
/// [`StageError`] when the topic fails.
pub fn publish_blank<S: Service>(
    publisher: &TopicPublisher<S, u8>,
    layout: &FrameLayout,
    id: u64,
    stamp: Stamp,
) -> Result<(), StageError> {
    let mut header = MsgHeader::new(FrameId(id), stamp);
    header.mark_received(Stage::Source);
    header.mark_started(Stage::Source);
    let mut sample = publisher.loan_frame(&header, layout)?;
    let planes = gfs_ipc::frame_view_mut(&mut sample, layout).map_err(|e| setup(e.to_string()))?;
    planes.gray.fill(0);
    planes.depth.fill(0.0);
    sample.user_header_mut().mark_finished(Stage::Source);
    publisher.send(sample)?;
    Ok(())
}

fn setup(message: String) -> StageError {
    StageError::Setup {
        stage: "source",
        message,
    }
}
