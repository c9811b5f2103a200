//! Typed publisher / subscriber ports of one topic of a run.
//!
//! Every topic is an iceoryx2 publish/subscribe service whose payload is a slice `[T]`
//! of a plain `#[repr(C)]` type and whose user header is [`MsgHeader`]: frames are
//! `[u8]` (see [`crate::frame`]), features are slices of feature structs, variable
//! messages are bincode `[u8]` (see [`crate::codec`]).
//!
//! Beside the publish/subscribe service, every topic has an iceoryx2 *event* service of
//! the same name: the publisher notifies it after each send and the subscriber can sleep
//! in [`TopicSubscriber::wait`] until then, instead of polling (publish/subscribe alone
//! has no blocking receive).

use std::fmt::Debug;
use std::time::Duration;

use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::{Alignment, AllocationStrategy, Node, ZeroCopySend};
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::service::Service;
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::event::PortFactory as EventService;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

use crate::error::IpcError;
use crate::header::MsgHeader;
use crate::qos::TopicQos;
use crate::run::IpcRun;

/// Payload alignment of every topic: enough for `f32`/`f64`/`u64` fields read in place
/// from a `[u8]` payload (iceoryx2 aligns `[u8]` payloads to 1 byte unless told).
pub const PAYLOAD_ALIGNMENT: usize = 8;

/// A received message: header via `user_header()`, payload via `payload()` (`&[T]`),
/// both borrowed from shared memory until the sample is dropped.
pub type TopicSample<S, T> = Sample<S, [T], MsgHeader>;

/// A loaned, writable message (see [`TopicPublisher::loan`]).
pub type TopicSampleMut<S, T> = SampleMut<S, [T], MsgHeader>;

/// The service of a topic (iceoryx2 port factory).
type TopicService<S, T> = PortFactory<S, [T], MsgHeader>;

fn open_service<S: Service, T: Debug + ZeroCopySend + 'static>(
    run: &IpcRun,
    node: &Node<S>,
    topic: &str,
    qos: &TopicQos,
) -> Result<(String, TopicService<S, T>), IpcError> {
    let name = run.service_name(topic)?;
    let full = name.as_str().to_string();
    let alignment = Alignment::new(PAYLOAD_ALIGNMENT).ok_or_else(|| IpcError::InvalidName {
        what: "payload alignment",
        value: PAYLOAD_ALIGNMENT.to_string(),
        reason: "not a power of two".to_string(),
    })?;
    let service = node
        .service_builder(&name)
        .publish_subscribe::<[T]>()
        .user_header::<MsgHeader>()
        .payload_alignment(alignment)
        .enable_safe_overflow(true)
        .history_size(qos.history)
        .subscriber_max_buffer_size(qos.subscriber_buffer)
        .subscriber_max_borrowed_samples(qos.max_borrowed)
        .max_publishers(qos.max_publishers)
        .max_subscribers(qos.max_subscribers)
        .max_nodes(qos.max_nodes)
        .open_or_create()
        .map_err(|reason| IpcError::Service {
            topic: full.clone(),
            reason,
        })?;
    Ok((full, service))
}

fn open_event<S: Service>(
    run: &IpcRun,
    node: &Node<S>,
    topic: &str,
    qos: &TopicQos,
) -> Result<EventService<S>, IpcError> {
    let name = run.service_name(topic)?;
    node.service_builder(&name)
        .event()
        .max_notifiers(qos.max_publishers)
        .max_listeners(qos.max_subscribers)
        .max_nodes(qos.max_nodes)
        .open_or_create()
        .map_err(|e| wakeup_error(name.as_str(), "event service", e))
}

fn wakeup_error(topic: &str, what: &'static str, reason: impl Debug) -> IpcError {
    IpcError::Wakeup {
        topic: topic.to_string(),
        what,
        reason: format!("{reason:?}"),
    }
}

/// The publishing end of a topic, carrying slices of `T`.
pub struct TopicPublisher<S: Service, T: Debug + ZeroCopySend + 'static> {
    topic: String,
    service: TopicService<S, T>,
    port: Publisher<S, [T], MsgHeader>,
    notifier: Notifier<S>,
}

impl<S: Service, T: Debug + ZeroCopySend + 'static> Debug for TopicPublisher<S, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TopicPublisher")
            .field("topic", &self.topic)
            .finish()
    }
}

impl<S: Service, T: Debug + ZeroCopySend + 'static> TopicPublisher<S, T> {
    /// Opens (or creates) `topic` of `run` with `qos` and attaches a publisher to it.
    ///
    /// `initial_max_len` is the slice length (in `T`s) the publisher's shared memory is
    /// sized for at creation; a longer loan makes iceoryx2 allocate a new, larger segment
    /// (power-of-two growth) that subscribers map on the fly, so it is a performance
    /// hint, not a limit. Size it for the usual message (e.g. the frame byte length).
    ///
    /// # Errors
    /// [`IpcError::Service`] when the service exists with an incompatible type or QoS,
    /// [`IpcError::Publisher`] when the publisher limit is reached or memory fails.
    pub fn create(
        run: &IpcRun,
        node: &Node<S>,
        topic: &str,
        qos: &TopicQos,
        initial_max_len: usize,
    ) -> Result<Self, IpcError> {
        let topic_name = topic;
        let (topic, service) = open_service::<S, T>(run, node, topic_name, qos)?;
        let port = service
            .publisher_builder()
            .initial_max_slice_len(initial_max_len.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|reason| IpcError::Publisher {
                topic: topic.clone(),
                reason,
            })?;
        let notifier = open_event(run, node, topic_name, qos)?
            .notifier_builder()
            .create()
            .map_err(|e| wakeup_error(&topic, "notifier", e))?;
        Ok(Self {
            topic,
            service,
            port,
            notifier,
        })
    }

    /// Subscribers attached to the topic now (every process of the run, and observers).
    pub fn subscriber_count(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// Full service name of the topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The iceoryx2 port, for what this wrapper does not cover.
    pub fn port(&self) -> &Publisher<S, [T], MsgHeader> {
        &self.port
    }

    /// Connects subscribers that appeared since the last send and delivers their
    /// history. `send` does this implicitly; a publisher that is idle while a restarted
    /// subscriber waits for history (lockstep source waiting on the tracker) must call
    /// it periodically, or the restarted stage never gets the frame it needs.
    ///
    /// # Errors
    /// [`IpcError::Connections`] when a subscriber's connection cannot be set up.
    pub fn update_connections(&self) -> Result<(), IpcError> {
        self.port
            .update_connections()
            .map_err(|reason| IpcError::Connections {
                topic: self.topic.clone(),
                reason,
            })
    }

    /// Sends `sample` and wakes the topic's waiting subscribers; returns how many
    /// subscribers it reached.
    ///
    /// # Errors
    /// [`IpcError::Send`] when iceoryx2 cannot deliver it (e.g. connection corrupted),
    /// [`IpcError::Wakeup`] when the notification fails (the sample was delivered).
    pub fn send(&self, sample: TopicSampleMut<S, T>) -> Result<usize, IpcError> {
        let reached = sample.send().map_err(|reason| IpcError::Send {
            topic: self.topic.clone(),
            reason,
        })?;
        self.notifier
            .notify()
            .map_err(|e| wakeup_error(&self.topic, "notify", e))?;
        Ok(reached)
    }
}

impl<S: Service, T: Debug + ZeroCopySend + Default + Copy + 'static> TopicPublisher<S, T> {
    /// Loans a sample of `len` default-initialised `T`s with `header` as its user header,
    /// to be filled in place (`payload_mut()`) and passed to [`Self::send`]: the
    /// zero-copy path, the producer writes straight into shared memory.
    ///
    /// # Errors
    /// [`IpcError::Loan`] when no sample is free (too many loaned) or memory is exhausted.
    pub fn loan(&self, header: &MsgHeader, len: usize) -> Result<TopicSampleMut<S, T>, IpcError> {
        let mut sample = self.port.loan_slice(len).map_err(|reason| IpcError::Loan {
            topic: self.topic.clone(),
            len,
            reason,
        })?;
        *sample.user_header_mut() = *header;
        Ok(sample)
    }
}

impl<S: Service, T: Debug + ZeroCopySend + Copy + 'static> TopicPublisher<S, T> {
    /// Publishes `data` (one copy into shared memory) with `header`; returns how many
    /// subscribers it reached.
    ///
    /// # Errors
    /// [`IpcError::Loan`] or [`IpcError::Send`] as for [`Self::loan`] / [`Self::send`].
    pub fn publish_slice(&self, header: &MsgHeader, data: &[T]) -> Result<usize, IpcError> {
        let mut sample =
            self.port
                .loan_slice_uninit(data.len())
                .map_err(|reason| IpcError::Loan {
                    topic: self.topic.clone(),
                    len: data.len(),
                    reason,
                })?;
        *sample.user_header_mut() = *header;
        self.send(sample.write_from_slice(data))
    }
}

/// The receiving end of a topic, carrying slices of `T`.
pub struct TopicSubscriber<S: Service, T: Debug + ZeroCopySend + 'static> {
    topic: String,
    service: TopicService<S, T>,
    port: Subscriber<S, [T], MsgHeader>,
    listener: Listener<S>,
}

impl<S: Service, T: Debug + ZeroCopySend + 'static> Debug for TopicSubscriber<S, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TopicSubscriber")
            .field("topic", &self.topic)
            .finish()
    }
}

impl<S: Service, T: Debug + ZeroCopySend + 'static> TopicSubscriber<S, T> {
    /// Opens (or creates) `topic` of `run` with `qos` and attaches a subscriber with a
    /// queue of `qos.subscriber_buffer` samples that requests `qos.history` old samples.
    ///
    /// # Errors
    /// [`IpcError::Service`] when the service exists with an incompatible type or QoS,
    /// [`IpcError::Subscriber`] when the subscriber limit is reached.
    pub fn create(
        run: &IpcRun,
        node: &Node<S>,
        topic: &str,
        qos: &TopicQos,
    ) -> Result<Self, IpcError> {
        let topic_name = topic;
        let (topic, service) = open_service::<S, T>(run, node, topic_name, qos)?;
        let port = service
            .subscriber_builder()
            .buffer_size(qos.subscriber_buffer)
            .history_request(qos.history)
            .create()
            .map_err(|reason| IpcError::Subscriber {
                topic: topic.clone(),
                reason,
            })?;
        let listener = open_event(run, node, topic_name, qos)?
            .listener_builder()
            .create()
            .map_err(|e| wakeup_error(&topic, "listener", e))?;
        Ok(Self {
            topic,
            service,
            port,
            listener,
        })
    }

    /// Publishers attached to the topic now.
    pub fn publisher_count(&self) -> usize {
        self.service.dynamic_config().number_of_publishers()
    }

    /// Full service name of the topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The iceoryx2 port, for what this wrapper does not cover.
    pub fn port(&self) -> &Subscriber<S, [T], MsgHeader> {
        &self.port
    }

    /// Sleeps until a publisher of the topic sent something or `timeout` passed; true
    /// when woken by a send. Drain the queue with [`Self::receive`] before waiting: history
    /// delivered on connection and samples sent before the subscriber existed come
    /// without a wake-up. The listener can also be attached to an iceoryx2 `WaitSet`
    /// ([`Self::listener`]) to wait on several topics at once.
    ///
    /// A wait cut short by a signal returns `Ok(false)`: the caller then looks at its
    /// stop request (a stage's SIGTERM) or simply waits again.
    ///
    /// # Errors
    /// [`IpcError::Wakeup`] when the wait fails for another reason.
    pub fn wait(&self, timeout: Duration) -> Result<bool, IpcError> {
        match self.listener.timed_wait(|_| (), timeout) {
            Ok(n) => Ok(n > 0),
            Err(ListenerWaitError::InterruptSignal) => Ok(false),
            Err(e) => Err(wakeup_error(&self.topic, "wait", e)),
        }
    }

    /// The wake-up listener of this subscriber (for an iceoryx2 `WaitSet`).
    pub fn listener(&self) -> &Listener<S> {
        &self.listener
    }

    /// The oldest queued sample, or `None` when the queue is empty. Never blocks.
    ///
    /// # Errors
    /// [`IpcError::Receive`] when the connection to a publisher is broken.
    pub fn receive(&self) -> Result<Option<TopicSample<S, T>>, IpcError> {
        self.port.receive().map_err(|reason| IpcError::Receive {
            topic: self.topic.clone(),
            reason,
        })
    }

    /// The newest queued sample, dropping older ones (realtime: a stage that fell
    /// behind takes the newest frame). `None` when the queue is empty. Never blocks.
    ///
    /// # Errors
    /// [`IpcError::Receive`] when the connection to a publisher is broken.
    pub fn receive_latest(&self) -> Result<Option<TopicSample<S, T>>, IpcError> {
        let mut latest = None;
        while let Some(sample) = self.receive()? {
            latest = Some(sample);
        }
        Ok(latest)
    }
}
