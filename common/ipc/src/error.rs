//! Errors of the transport layer. Each variant says which run / topic / port failed and
//! carries the iceoryx2 reason.

use iceoryx2::node::{NodeCreationFailure, NodeListFailure};
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::subscriber::SubscriberCreateError;
use iceoryx2::port::update_connections::ConnectionFailure;
use iceoryx2::port::{LoanError, ReceiveError, SendError};
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use thiserror::Error;

use crate::codec::CodecError;
use crate::frame::FrameError;

/// A transport operation failed.
#[derive(Debug, Error)]
pub enum IpcError {
    /// A run id, topic or node name is not usable as an iceoryx2 name.
    #[error("invalid {what} {value:?}: {reason}")]
    InvalidName {
        /// Which kind of name ("run id", "service name", "node name", "prefix", "payload alignment").
        what: &'static str,
        /// The rejected value.
        value: String,
        /// Why it was rejected.
        reason: String,
    },
    /// Another live run holds the run id.
    #[error("run id {run} is in use by {by}: pick another --run-id or stop that run")]
    RunInUse {
        /// Run id.
        run: String,
        /// Who holds it.
        by: String,
    },
    /// A lock file could not be created or locked.
    #[error("cannot lock {path}: {source}")]
    Lock {
        /// The lock file.
        path: std::path::PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The iceoryx2 node could not be created.
    #[error("run {run}: cannot create node {node:?}: {reason:?}")]
    Node {
        /// Run id.
        run: String,
        /// Node name.
        node: String,
        /// iceoryx2 reason.
        reason: NodeCreationFailure,
    },
    /// SIGINT / SIGTERM arrived while a stage node was being set up.
    #[error("run {run}: termination requested while creating node {node:?}")]
    TerminationRequested {
        /// Run id.
        run: String,
        /// Node name.
        node: String,
    },
    /// The nodes of a run could not be listed (dead-node scan).
    #[error("run {run}: cannot list nodes: {reason:?}")]
    NodeList {
        /// Run id.
        run: String,
        /// iceoryx2 reason.
        reason: NodeListFailure,
    },
    /// The publish/subscribe service of a topic could not be opened or created (for
    /// example an incompatible payload type or QoS from another process).
    #[error("topic {topic}: cannot open or create the service: {reason:?}")]
    Service {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: PublishSubscribeOpenOrCreateError,
    },
    /// A publisher port could not be created (e.g. too many publishers).
    #[error("topic {topic}: cannot create a publisher: {reason:?}")]
    Publisher {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: PublisherCreateError,
    },
    /// A subscriber port could not be created (e.g. too many subscribers).
    #[error("topic {topic}: cannot create a subscriber: {reason:?}")]
    Subscriber {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: SubscriberCreateError,
    },
    /// No sample of `len` elements could be loaned.
    #[error("topic {topic}: cannot loan a sample of {len} elements: {reason:?}")]
    Loan {
        /// Full service name.
        topic: String,
        /// Requested slice length in elements.
        len: usize,
        /// iceoryx2 reason.
        reason: LoanError,
    },
    /// A sample could not be delivered.
    #[error("topic {topic}: cannot send: {reason:?}")]
    Send {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: SendError,
    },
    /// Receiving failed (not "no sample": that is `Ok(None)`).
    #[error("topic {topic}: cannot receive: {reason:?}")]
    Receive {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: ReceiveError,
    },
    /// Connecting to new subscribers (and delivering their history) failed.
    #[error("topic {topic}: cannot update connections: {reason:?}")]
    Connections {
        /// Full service name.
        topic: String,
        /// iceoryx2 reason.
        reason: ConnectionFailure,
    },
    /// A variable-size message could not be encoded.
    #[error("topic {topic}: {source}")]
    Encode {
        /// Full service name.
        topic: String,
        /// What went wrong.
        #[source]
        source: CodecError,
    },
    /// A frame could not be laid out or its images do not fit.
    #[error("topic {topic}: {source}")]
    Frame {
        /// Full service name.
        topic: String,
        /// What went wrong.
        #[source]
        source: FrameError,
    },
    /// The wake-up event of a topic (notifier / listener) failed.
    #[error("topic {topic}: wake-up {what} failed: {reason}")]
    Wakeup {
        /// Full service name.
        topic: String,
        /// The failed step ("event service", "notifier", "listener", "notify", "wait").
        what: &'static str,
        /// iceoryx2 reason (debug text of its error enum).
        reason: String,
    },
}
