//! Requests from outside a run to its stages (the ROS 2 stage's services and topics),
//! on the `control` topic (bincode). The topic keeps its last messages for a restarted
//! subscriber, so each request carries a number and a stage applies each number once
//! (it keeps the last one applied in its state folder).

use crate::state::{StateDir, StateError};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// What a stage is asked to do.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Control {
    /// Start a new map; the odometry goes on from the last pose.
    Reset,
    /// Start a new map with the camera at this `world_from_camera` (odometry frame),
    /// at rest; the odometry goes on from there.
    ResetToPose(Isometry3<f64>),
    /// Localising in a loaded map: the camera is near this `world_from_camera` (the
    /// map's frame); the next frame is tracked from there against the map around it,
    /// as `--initial-pose` places the first frame.
    RelocaliseNear(Isometry3<f64>),
}

/// A request and its number.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControlMessage {
    /// Increasing over the run, also across restarts of the sender: the monotonic
    /// clock when it was sent, in nanoseconds.
    pub seq: u64,
    /// The request.
    pub control: Control,
}

/// The numbers of the requests a stage applied: each is applied once, even when the
/// topic's history brings it to a restarted stage again.
pub struct ControlLedger {
    file: &'static str,
    last: u64,
}

impl ControlLedger {
    /// The ledger saved in `state` under `file` (none applied when there is none).
    ///
    /// # Errors
    /// [`StateError`] when the file exists but cannot be read.
    pub fn open(state: &StateDir, file: &'static str) -> Result<Self, StateError> {
        Ok(Self {
            file,
            last: state.read::<u64>(file)?.unwrap_or(0),
        })
    }

    /// True when `message` was not applied yet.
    pub fn is_new(&self, message: &ControlMessage) -> bool {
        message.seq > self.last
    }

    /// Records `message` as applied.
    ///
    /// # Errors
    /// [`StateError`] when the state cannot be written.
    pub fn applied(
        &mut self,
        state: &StateDir,
        message: &ControlMessage,
        scratch: &mut Vec<u8>,
    ) -> Result<(), StateError> {
        self.last = self.last.max(message.seq);
        state.write(self.file, &self.last, scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_request_is_applied_once_also_by_a_restarted_stage() {
        let dir = std::env::temp_dir().join(format!("gfs-control-{}", std::process::id()));
        let state = StateDir::new(Some(dir.clone()));
        let mut scratch = Vec::new();
        let message = |seq| ControlMessage {
            seq,
            control: Control::Reset,
        };
        let mut ledger = ControlLedger::open(&state, "control.bin").unwrap();
        assert!(ledger.is_new(&message(10)));
        ledger.applied(&state, &message(10), &mut scratch).unwrap();
        assert!(!ledger.is_new(&message(10)), "applied already");
        // A restarted stage gets the topic's history again: only the newer one is new.
        let reopened = ControlLedger::open(&state, "control.bin").unwrap();
        assert!(!reopened.is_new(&message(10)) && reopened.is_new(&message(11)));
        let pose = Control::ResetToPose(Isometry3::translation(1.0, 2.0, 3.0));
        let mut bytes = Vec::new();
        gfs_ipc::encode_message(
            &ControlMessage {
                seq: 12,
                control: pose,
            },
            &mut bytes,
        )
        .unwrap();
        let decoded: ControlMessage =
            gfs_ipc::decode_message(&bytes, gfs_ipc::MAX_VARIABLE_MESSAGE_BYTES).unwrap();
        assert_eq!(decoded.control, pose);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
