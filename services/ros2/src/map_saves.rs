//! The `/gfsvo/save_map` service (`std_srvs/srv/Trigger`): each call becomes a
//! [`SaveMapRequest`] to the mapper for `--save-map`'s file, answered when the mapper's
//! [`SaveMapReply`] comes back (the file, its size and keyframes, or the error), or with
//! failure after [`SAVE_TIMEOUT`]; the stage's loop never waits for it.

use crate::dds::{DdsError, TriggerRequest, TriggerResponse};
use gfs_ipc::{
    MAX_VARIABLE_MESSAGE_BYTES, MsgHeader, TopicPublisher, TopicSubscriber, ipc, monotonic_ns,
    topics,
};
use gfs_pipeline::map_files::{SaveMapReply, SaveMapRequest};
use gfs_pipeline::stages::StageContext;
use ros2_client::{RmwRequestId, Server};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How long a call waits for the mapper (writing a map takes well under a second; the
/// mapper answers between keyframes).
pub const SAVE_TIMEOUT: Duration = Duration::from_secs(10);

/// A call passed on to the mapper, not answered yet.
struct Pending {
    id: u64,
    call: RmwRequestId,
    deadline: Instant,
}

/// The service's calls in flight and the mapper's topics.
pub struct MapSaves {
    service: String,
    path: Option<PathBuf>,
    requests: TopicPublisher<ipc::Service, u8>,
    replies: TopicSubscriber<ipc::Service, u8>,
    pending: Vec<Pending>,
    bytes: Vec<u8>,
}

impl MapSaves {
    /// The service `service` saving to `path` (`--save-map`; `None`: every call fails,
    /// saying so).
    ///
    /// # Errors
    /// [`DdsError`] when the topics cannot be opened.
    pub fn open(
        ctx: &StageContext<ipc::Service>,
        service: &str,
        path: Option<PathBuf>,
    ) -> Result<Self, DdsError> {
        Ok(Self {
            service: service.to_owned(),
            path,
            requests: ctx.publish(topics::SAVE_MAP, 256)?,
            replies: ctx.subscribe(topics::MAP_SAVED)?,
            pending: Vec::new(),
            bytes: Vec::new(),
        })
    }

    /// Passes the calls received on `server` to the mapper, answers those the mapper
    /// answered and those that waited too long; true when anything came.
    ///
    /// # Errors
    /// [`DdsError`] when a topic fails.
    pub fn serve(
        &mut self,
        server: &Server<TriggerRequest, TriggerResponse>,
    ) -> Result<bool, DdsError> {
        let mut any = false;
        loop {
            match server.receive_request() {
                Ok(Some((call, _))) => {
                    any = true;
                    self.ask(server, call)?;
                }
                Ok(None) => break,
                Err(e) => {
                    tracing::warn!("{}: undecodable request: {e:?}", self.service);
                    break;
                }
            }
        }
        while let Some((_, reply)) = self
            .replies
            .receive_decoded::<SaveMapReply>(MAX_VARIABLE_MESSAGE_BYTES)?
        {
            any = true;
            let Some(i) = self.pending.iter().position(|p| p.id == reply.id) else {
                continue;
            };
            let call = self.pending.swap_remove(i).call;
            let path = reply.path.display();
            let response = match reply.result {
                Ok(bytes) => TriggerResponse {
                    success: true,
                    message: format!("{path}: {} keyframes, {bytes} bytes", reply.keyframes),
                },
                Err(e) => TriggerResponse {
                    success: false,
                    message: e,
                },
            };
            self.respond(server, call, response);
        }
        let now = Instant::now();
        while let Some(i) = self.pending.iter().position(|p| p.deadline <= now) {
            let call = self.pending.swap_remove(i).call;
            let message = format!(
                "the mapper did not answer within {} s; the map may still be written",
                SAVE_TIMEOUT.as_secs()
            );
            self.respond(server, call, failure(message));
        }
        if !self.pending.is_empty() {
            // A mapper restarted since the call gets the request from the history.
            self.requests.update_connections()?;
        }
        Ok(any)
    }

    fn ask(
        &mut self,
        server: &Server<TriggerRequest, TriggerResponse>,
        call: RmwRequestId,
    ) -> Result<(), DdsError> {
        let Some(path) = &self.path else {
            let message = "no map file to save to: start gfsvo ros2 with --save-map FILE";
            self.respond(server, call, failure(message.to_owned()));
            return Ok(());
        };
        // Unique across restarts of this stage, as the control topic's numbers.
        let request = SaveMapRequest {
            id: monotonic_ns(),
            path: path.clone(),
        };
        self.requests.update_connections()?;
        self.requests
            .publish_encoded(&MsgHeader::default(), &request, &mut self.bytes)?;
        tracing::info!(
            "{}: asking the mapper to write {}",
            self.service,
            path.display()
        );
        self.pending.push(Pending {
            id: request.id,
            call,
            deadline: Instant::now() + SAVE_TIMEOUT,
        });
        Ok(())
    }

    fn respond(
        &self,
        server: &Server<TriggerRequest, TriggerResponse>,
        call: RmwRequestId,
        response: TriggerResponse,
    ) {
        if response.success {
            tracing::info!("{}: {}", self.service, response.message);
        } else {
            tracing::warn!("{}: {}", self.service, response.message);
        }
        if let Err(e) = server.send_response(call, response) {
            tracing::warn!("{}: the reply was not sent: {e:?}", self.service);
        }
    }
}

fn failure(message: String) -> TriggerResponse {
    TriggerResponse {
        success: false,
        message,
    }
}
