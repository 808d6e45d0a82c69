//! The DDS plumbing shared by both sides: a node on a domain, topics with pbd's QoS, and a poll to
//! wait on subscriptions with a deadline.

use std::time::{Duration, Instant};

use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Subscription};
use rustdds::mio1::{Events, Interest, Poll, Token};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::Ros2Error;

fn dds(what: impl Into<String>, e: impl std::fmt::Debug) -> Ros2Error {
    Ros2Error::Dds {
        what: what.into(),
        message: format!("{e:?}"),
    }
}

/// Reliable, transient-local, the newest sample only: a reader that joins late still gets the last
/// state, command or trigger (a volatile one would lose what was sent before discovery matched it,
/// and a lock-step peer would wait forever). Compatible with ROS 2's default (volatile) readers.
pub(crate) fn qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(500)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// A node and the poll its subscriptions are registered with.
pub(crate) struct Endpoint {
    _context: Context,
    pub(crate) node: Node,
    poll: Poll,
    events: Events,
    next_token: usize,
}

impl Endpoint {
    pub(crate) fn new(domain: u16, namespace: Option<&str>, name: &str) -> Result<Self, Ros2Error> {
        let context = Context::with_options(ros2_client::context::ContextOptions::new().domain_id(domain))
            .map_err(|e| dds(format!("domain {domain}"), e))?;
        let node_name = NodeName::new(namespace.unwrap_or("/"), name).map_err(|e| dds(format!("node {name}"), e))?;
        let node = context
            .new_node(node_name, NodeOptions::new())
            .map_err(|e| dds(format!("node {name}"), e))?;
        Ok(Endpoint {
            _context: context,
            node,
            poll: Poll::new().map_err(|e| dds("poll", e))?,
            events: Events::with_capacity(64),
            next_token: 0,
        })
    }

    fn topic(&mut self, topic: &str, ty: (&str, &str)) -> Result<rustdds::Topic, Ros2Error> {
        let name = Name::parse(topic).map_err(|e| dds(topic, e))?;
        self.node
            .create_topic(&name, MessageTypeName::new(ty.0, ty.1), &qos())
            .map_err(|e| dds(topic, e))
    }

    pub(crate) fn publisher<M: Serialize>(&mut self, topic: &str, ty: (&str, &str)) -> Result<Publisher<M>, Ros2Error> {
        let t = self.topic(topic, ty)?;
        self.node.create_publisher(&t, None).map_err(|e| dds(topic, e))
    }

    pub(crate) fn subscription<M: DeserializeOwned + 'static>(
        &mut self,
        topic: &str,
        ty: (&str, &str),
    ) -> Result<Subscription<M>, Ros2Error> {
        let t = self.topic(topic, ty)?;
        let mut sub = self.node.create_subscription(&t, None).map_err(|e| dds(topic, e))?;
        self.poll
            .registry()
            .register(&mut sub, Token(self.next_token), Interest::READABLE)
            .map_err(|e| dds(topic, e))?;
        self.next_token += 1;
        Ok(sub)
    }

    /// Sleeps until a subscription has data or `deadline` passes (whichever is first).
    pub(crate) fn wait(&mut self, deadline: Instant) {
        let now = Instant::now();
        if now >= deadline {
            return;
        }
        // A short cap: readiness is edge-triggered, and a sample that arrived between the last
        // drain and this poll must not cost a whole timeout.
        let timeout = (deadline - now).min(Duration::from_millis(5));
        let _ = self.poll.poll(&mut self.events, Some(timeout));
    }
}

/// Publishes, naming the topic on failure.
pub(crate) fn publish<M: Serialize>(p: &Publisher<M>, topic: &str, m: M) -> Result<(), Ros2Error> {
    use ros2_client::WriteError as W;
    p.publish(m).map_err(|e| {
        let why = match e {
            W::Serialization { reason, .. }
            | W::Poisoned { reason, .. }
            | W::Internal { reason }
            | W::Middleware { reason, .. } => reason,
            W::Io(e) => e.to_string(),
            W::WouldBlock { .. } => "the send window stayed full (is the reader alive?)".into(),
        };
        Ros2Error::Message {
            topic: topic.to_string(),
            message: format!("publish failed: {why}"),
        }
    })
}

/// The next sample of `sub`, if any; a sample that does not deserialise is an error naming the topic.
pub(crate) fn take<M: DeserializeOwned + 'static>(sub: &Subscription<M>, topic: &str) -> Result<Option<M>, Ros2Error> {
    match sub.take() {
        Ok(Some((m, _))) => Ok(Some(m)),
        Ok(None) => Ok(None),
        Err(e) => Err(Ros2Error::Message {
            topic: topic.to_string(),
            message: format!("cannot read a sample: {e:?}"),
        }),
    }
}
