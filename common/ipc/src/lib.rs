//! GFS-VO inter-process plumbing over iceoryx2 0.10: topics, message layouts, stage
//! stamps, run isolation and dead-node cleanup.
//!
//! **Why.** The pipeline stages (source, points, lines, planes, tracker, mapper) run as
//! separate processes that exchange frames and features through shared memory without
//! serialisation on the hot path (DESIGN.md "Messages"). This crate is everything the
//! stage services share about that exchange; it holds no algorithm.
//!
//! **Model.**
//! - A *run* ([`IpcRun`]) is one iceoryx2 universe with its own file prefix
//!   `gfsvo_<run-id>_`, so runs and tests never see each other, and
//!   [`IpcRun::leftovers`] tells whether anything of it is left in `/dev/shm` or
//!   `/tmp/iceoryx2`.
//! - A *topic* is a publish/subscribe service `gfsvo/<run-id>/<topic>` whose payload is a
//!   slice `[T]` of a plain `#[repr(C)]` type and whose user header is [`MsgHeader`]
//!   (frame id, capture time, per-stage monotonic stamps). [`TopicPublisher`] and
//!   [`TopicSubscriber`] are its ends; [`TopicQos`] sizes its queues for the
//!   [`Mode`] (lockstep / realtime); [`topics`] names the pipeline's topics.
//! - Payloads: a frame is a `[u8]` in the fixed [`frame`] layout read in place as
//!   [`gfs_core::ImageView`]s; features are `&[T]` of `ZeroCopySend + Copy` structs;
//!   rare variable messages are bincode ([`codec`]) decoded with a size limit, and a
//!   malformed one is logged and dropped.
//! - The same code runs between processes ([`ipc::Service`]) or between threads of one
//!   process ([`local::Service`]): every port is generic over the [`Service`] variant.
//! - [`profile`]: the per-frame stage stamps of a run gathered by the recorder, as
//!   `profile.json`, with median / p90 / p99 / max per stage.
//! - Wake-ups: each topic also has an iceoryx2 event service; a publisher notifies it on
//!   every send and [`TopicSubscriber::wait`] sleeps until then (bounded by a timeout).
//! - Wire structs for features are defined by the services as `#[repr(C)]` types with
//!   `#[derive(ZeroCopySend)]` (re-exported here, so a service needs no direct iceoryx2
//!   dependency) and `#[type_name("gfsvo::...")]`, a stable name both ends agree on.
//!
//! **iceoryx2 0.10 behaviour to know** (each one cost a debugging session):
//! - History is delivered to a new subscriber only when the *publisher* updates its
//!   connections (on `send`, or [`TopicPublisher::update_connections`]). A lockstep
//!   publisher idling while a restarted stage waits for history must call it; and a
//!   subscriber receives at most `min(history, its buffer)` old samples, without a wake-up.
//! - Shared memory per publisher is preallocated for the worst case,
//!   `max_subscribers * (buffer + borrowed) + history + loans` samples of the initial
//!   slice length; longer loans grow it (power-of-two) by mapping new segments.
//! - `[u8]` payloads are 1-byte aligned unless the service asks for more: every topic
//!   asks for [`PAYLOAD_ALIGNMENT`] so that `f32` planes can be read in place.
//! - Event sockets live at `<root><prefix><39-digit id>.event` and must fit the 107
//!   bytes of a Unix socket path: run ids are short and the root stays `/tmp/iceoryx2/`.
//! - Each prefix ("domain") has a node-counter segment `…global_mgmt` in `/dev/shm` that
//!   no node removes; [`IpcRun::finish`] removes it when the run is over.
//! - Samples a subscriber has not yet connected to (it connects on `receive`) vanish
//!   when their publisher is dropped: a publisher that exits right after sending loses
//!   them. Once connected, a subscriber still receives what a dropped publisher had
//!   queued for it.
//! - Ports of `ipc::Service` / `local::Service` are not `Send` (they hold `Rc`s): in
//!   `threads` mode each thread creates its own node and ports.
//! - A SIGKILLed process's node, ports, connections and data segments stay until some
//!   process calls [`IpcRun::cleanup_dead_nodes`] (new nodes and opened services also
//!   clean up dead nodes by default); its samples then return to the publishers.
//!
//! ```
//! use gfs_core::{ids::FrameId, stamp::Stamp, Image};
//! use gfs_ipc::{frame_view, topics, FrameImages, IpcRun, Mode, MsgHeader, RunId, Stage,
//!     TopicPublisher, TopicSubscriber};
//! use gfs_ipc::local;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let run = IpcRun::new(RunId::unique("doc")?)?;
//! let node = run.node::<local::Service>("source")?;
//! let (topic, qos) = (topics::FRAME.name, topics::FRAME.qos(Mode::Lockstep));
//! let publisher = TopicPublisher::<local::Service, u8>::create(&run, &node, topic, &qos, 1 << 16)?;
//! let subscriber = TopicSubscriber::<local::Service, u8>::create(&run, &node, topic, &qos)?;
//!
//! let (gray, depth) = (Image::<u8>::new(64, 48), Image::<f32>::new(64, 48));
//! let mut header = MsgHeader::new(FrameId(0), Stamp::from_nanos(33_000_000));
//! header.mark_finished(Stage::Source);
//! let images = FrameImages { gray: gray.view(), depth: depth.view(), rgb: None };
//! publisher.publish_frame(&header, &images)?;
//!
//! let sample = subscriber.receive()?.expect("one frame is queued");
//! let frame = frame_view(&sample)?;
//! assert_eq!((frame.gray().width(), frame.depth().height()), (64, 48));
//! assert_eq!(sample.user_header().frame(), FrameId(0));
//! # Ok(())
//! # }
//! ```
#![warn(missing_docs)]

mod clock;
pub mod codec;
mod error;
pub mod frame;
mod header;
mod lock;
mod messages;
pub mod profile;
mod qos;
mod run;
mod sweep;
mod topic;
pub mod topics;

pub use clock::monotonic_ns;
pub use codec::{CodecError, MAX_VARIABLE_MESSAGE_BYTES, decode_message, encode_message};
pub use error::IpcError;
pub use frame::{FrameError, FrameImages, FrameLayout, FrameView, FrameViewMut};
pub use header::{MsgHeader, Stage, StageStamp};
pub use lock::{FileLock, Holder};
pub use messages::{frame_view, frame_view_mut};
pub use profile::{Profile, ProfileError, ProfileSummary};
pub use qos::{Mode, TopicKind, TopicQos};
pub use run::{
    CleanupReport, IPC_ROOT, IpcRun, MAX_RUN_ID_LEN, NodeInfo, RUN_ID_ENV, RunId, SHM_DIR,
};
pub use sweep::{
    LOCK_DIR, Liveness, RunClaim, STARTING_GRACE, SweepReport, runs_on_disk, sweep_dead_runs,
};
pub use topic::{PAYLOAD_ALIGNMENT, TopicPublisher, TopicSample, TopicSampleMut, TopicSubscriber};

/// The iceoryx2 names a stage needs: the service variants, the variant trait, and the
/// `ZeroCopySend` trait + derive for wire structs.
pub use iceoryx2::prelude::{ZeroCopySend, ipc, local};
pub use iceoryx2::service::Service;
