//! Requests to the tracker over ROS 2, passed on on the pipeline's `control` topic: the
//! reset service, a reset to a pose, and a pose hint in the loaded map (`/initialpose`).

use crate::dds::{DdsError, EmptyResponse, Endpoints};
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_ipc::{MsgHeader, TopicPublisher, ipc, monotonic_ns};
use gfs_pipeline::control::{Control, ControlMessage};
use gfs_ros2::Ros2Config;
use gfs_ros2::control::{hint_pose, reset_pose};
use gfs_ros2::msg::PoseWithCovarianceStamped;
use gfs_ros2::odom::OdometryPublisherState;

/// Where the requests asked for over ROS 2 come from and go to.
pub struct Requests<'a> {
    /// The node's endpoints.
    pub dds: &'a Endpoints,
    /// The pipeline's `control` topic.
    pub control: &'a TopicPublisher<ipc::Service, u8>,
    /// The frames and the camera in the base, to check and convert poses.
    pub odometry: &'a OdometryPublisherState,
    /// The topic and service names.
    pub ros2: &'a Ros2Config,
    /// The run localises in a loaded map (`--load-map --localize`): pose hints apply.
    pub localising: bool,
}

impl Requests<'_> {
    /// Sends the requests received since the last call to the tracker (which applies
    /// them before the next frame it can, `next_frame` or later) and answers the service
    /// calls; true when any came. A bad pose is refused with a warning.
    ///
    /// # Errors
    /// [`DdsError`] when the `control` topic fails.
    pub fn pass_on(&self, next_frame: u64, scratch: &mut Vec<u8>) -> Result<bool, DdsError> {
        let mut any = false;
        loop {
            match self.dds.reset.receive_request() {
                Ok(Some((id, _))) => {
                    any = true;
                    self.send(Control::Reset, next_frame, scratch)?;
                    tracing::info!("{}: a new map from the next frame", self.ros2.reset_service);
                    if let Err(e) = self.dds.reset.send_response(id, EmptyResponse::default()) {
                        tracing::warn!(
                            "{}: the reply was not sent: {e:?}",
                            self.ros2.reset_service
                        );
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    tracing::warn!("{}: undecodable request: {e:?}", self.ros2.reset_service);
                    break;
                }
            }
        }
        let topic = &self.ros2.reset_to_pose_topic;
        while let Some(message) = take_pose(&self.dds.reset_to_pose, topic) {
            any = true;
            match reset_pose(&message, topic, self.odometry) {
                Ok(pose) => {
                    self.send(Control::ResetToPose(pose), next_frame, scratch)?;
                    tracing::info!("{topic}: a new map from the next frame, at {pose}");
                }
                Err(e) => tracing::warn!("{e}"),
            }
        }
        let topic = &self.ros2.initial_pose_topic;
        while let Some(message) = take_pose(&self.dds.initial_pose, topic) {
            any = true;
            match hint_pose(&message, topic, self.odometry) {
                Ok(pose) if self.localising => {
                    self.send(Control::RelocaliseNear(pose), next_frame, scratch)?;
                    tracing::info!("{topic}: the next frame is looked for near {pose}");
                }
                Ok(_) => tracing::warn!(
                    "{topic} at {}: ignored: a pose hint places the camera in a loaded map \
                     (gfsvo ros2 --load-map FILE --localize); {} starts a new map at a pose",
                    Stamp::from(message.header.stamp),
                    self.ros2.reset_to_pose_topic
                ),
                Err(e) => tracing::warn!("{e}"),
            }
        }
        Ok(any)
    }

    fn send(&self, control: Control, frame: u64, scratch: &mut Vec<u8>) -> Result<(), DdsError> {
        let message = ControlMessage {
            seq: monotonic_ns(),
            control,
        };
        let header = MsgHeader::new(FrameId(frame), Stamp::now());
        self.control.publish_encoded(&header, &message, scratch)?;
        Ok(())
    }
}

/// The next pose received on `topic`, if any (an undecodable one is named and dropped).
fn take_pose(
    subscription: &ros2_client::Subscription<PoseWithCovarianceStamped>,
    topic: &str,
) -> Option<PoseWithCovarianceStamped> {
    match subscription.take() {
        Ok(Some((message, _))) => Some(message),
        Ok(None) => None,
        Err(e) => {
            tracing::warn!("{topic}: undecodable message: {e:?}");
            None
        }
    }
}
