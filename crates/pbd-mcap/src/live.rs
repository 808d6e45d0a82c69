//! # Live view: a run streamed to Foxglove over its WebSocket protocol while it happens
//!
//! A [`LiveView`] is a Foxglove WebSocket server (the `foxglove` SDK, protocol
//! `foxglove.sdk.v1`, the successor of `foxglove.websocket.v1`) that carries the same channels, schemas and messages (Protobuf for Foxglove's schemas, JSON for pbd's own) as the MCAP
//! log: every [`McapLog`](crate::McapLog) it is attached to with
//! [`McapLog::stream_to`](crate::McapLog::stream_to) sends each message both to the file
//! and to the connected clients. Writing the file does not change. In Foxglove: *Open connection →
//! Foxglove WebSocket → `ws://127.0.0.1:8765`*, then import `assets/foxglove/pbd-layout.json`.
//!
//! - **Off unless asked**: nothing listens until [`LiveView::start`]. The CLI binds `127.0.0.1`
//!   (this machine only) unless `--bind` says otherwise.
//! - **Late joiners see the world**: the robot and the scene are written once per run (`/robot`,
//!   `/scene`); the live view keeps the last message of each and sends it to each client once, when
//!   it subscribes to the topic, so a client that connects in the middle of a run (or between its
//!   steps) draws the robot and the table at once — and nothing is sent twice (the 3D panel keeps
//!   scene entities until they are replaced).
//! - **Time**: messages carry the simulated time (ns from the start of the run) as their log
//!   time, as in the file.
//! - One view may serve several logs in turn (`pbd demo`: the demonstration, then the
//!   execution): channels are shared by topic.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, Weak};

use anyhow::{Context as _, Result};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer, WebSocketServerHandle};

/// Topics whose last message each client receives when it subscribes (see the module
/// documentation).
const LATCHED: [&str; 2] = [crate::topics::TOPIC_ROBOT, crate::topics::TOPIC_SCENE];

/// Messages queued per client; a viewer slower than the run loses the oldest beyond this.
pub const MESSAGE_BACKLOG: usize = 4096;

/// The default address of `--live`: this machine only, Foxglove's usual port.
pub const DEFAULT_BIND: &str = "127.0.0.1:8765";

/// Whether and where a run is shown live — the one option of every command that can serve a live
/// view (`record`, `execute`, `demo`). Deserialises from an address string too (`"127.0.0.1:8765"`),
/// so a script can write `live = "127.0.0.1:8765"`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "LiveSetting")]
pub struct LiveOptions {
    /// Serve on this address (`HOST:PORT`, e.g. [`DEFAULT_BIND`]) as well as writing the log;
    /// `None`: no network listener.
    pub bind: Option<String>,
    /// A live view already running (shared by several steps, e.g. `pbd demo`'s); takes precedence
    /// over `bind`. Not part of the serialised options.
    #[serde(skip)]
    pub view: Option<LiveView>,
}

/// What [`LiveOptions`] deserialises from: an address, or `{bind}`.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum LiveSetting {
    Address(Option<String>),
    Table {
        #[serde(default)]
        bind: Option<String>,
    },
}

impl From<LiveSetting> for LiveOptions {
    fn from(s: LiveSetting) -> Self {
        let (LiveSetting::Address(bind) | LiveSetting::Table { bind }) = s;
        LiveOptions { bind, view: None }
    }
}

impl LiveOptions {
    /// Serve on `bind` (`None`: no listener).
    pub fn bind(bind: Option<String>) -> Self {
        LiveOptions { bind, view: None }
    }

    /// Stream to a view already running.
    pub fn view(view: &LiveView) -> Self {
        LiveOptions {
            bind: None,
            view: Some(view.clone()),
        }
    }

    /// Whether a live view is asked for.
    pub fn is_on(&self) -> bool {
        self.bind.is_some() || self.view.is_some()
    }

    /// The view to stream to: the running one if given, else a new one on `bind`, else none.
    pub fn start(&self) -> Result<Option<LiveView>> {
        LiveView::from_options(self.bind.as_deref(), self.view.as_ref())
    }
}

/// A running Foxglove WebSocket server that logs stream to; cheap to clone (all clones are the
/// same server). The server stops when the last clone is dropped.
#[derive(Clone)]
pub struct LiveView {
    inner: Arc<Mutex<Inner>>,
    port: u16,
    host: String,
}

struct Inner {
    context: Arc<Context>,
    server: Option<WebSocketServerHandle>,
    /// Channels by topic.
    channels: HashMap<String, Arc<RawChannel>>,
    /// The last message of each latched topic.
    latched: HashMap<String, Vec<u8>>,
    /// The latest log time sent (ns).
    last_time: u64,
}

/// Sends a latched topic's last message to a client that subscribes to it (only to that client).
struct Latch {
    inner: OnceLock<Weak<Mutex<Inner>>>,
}

impl ServerListener for Latch {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let (Some(inner), Some(sink)) = (self.inner.get().and_then(Weak::upgrade), client.sink_id()) else {
            return;
        };
        let inner = inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let topic = channel.topic();
        if let (Some(msg), Some(c)) = (inner.latched.get(topic), inner.channels.get(topic)) {
            c.log_with_meta_to_sink(msg, PartialMetadata::with_log_time(inner.last_time), Some(sink));
        }
    }
}

impl Drop for Inner {
    fn drop(&mut self) {
        if let Some(server) = self.server.take() {
            // Closes the listener and the client connections; do not wait for them.
            drop(server.stop());
        }
    }
}

impl std::fmt::Debug for LiveView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveView")
            .field("url", &self.url())
            .finish_non_exhaustive()
    }
}

impl PartialEq for LiveView {
    /// The same server.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.inner, &other.inner)
    }
}

impl LiveView {
    /// Starts a server on `bind` (`host:port`; port 0 picks a free one, see [`LiveView::port`]).
    pub fn start(bind: &str) -> Result<Self> {
        let (host, port) = bind
            .rsplit_once(':')
            .and_then(|(h, p)| Some((h.trim_start_matches('[').trim_end_matches(']'), p.parse::<u16>().ok()?)))
            .with_context(|| format!("--bind `{bind}`: expected HOST:PORT, e.g. {DEFAULT_BIND}"))?;
        anyhow::ensure!(!host.is_empty(), "--bind `{bind}`: no host; e.g. {DEFAULT_BIND}");
        let context = Context::new();
        let latch = Arc::new(Latch { inner: OnceLock::new() });
        let server = WebSocketServer::new()
            .name("pbd")
            .bind(host, port)
            .message_backlog_size(MESSAGE_BACKLOG)
            .listener(latch.clone())
            .context(&context)
            .start_blocking()
            .with_context(|| format!("cannot start the live view on {bind}"))?;
        let port = server.port();
        let inner = Arc::new(Mutex::new(Inner {
            context,
            server: Some(server),
            channels: HashMap::new(),
            latched: HashMap::new(),
            last_time: 0,
        }));
        let _ = latch.inner.set(Arc::downgrade(&inner));
        Ok(Self {
            inner,
            port,
            host: host.to_owned(),
        })
    }

    /// The view to stream to: `view` if given, else a new one on `bind`, else none.
    pub fn from_options(bind: Option<&str>, view: Option<&LiveView>) -> Result<Option<LiveView>> {
        match (view, bind) {
            (Some(v), _) => Ok(Some(v.clone())),
            (None, Some(b)) => Self::start(b).map(Some),
            (None, None) => Ok(None),
        }
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// `ws://host:port`, what a Foxglove client connects to.
    pub fn url(&self) -> String {
        if self.host.contains(':') {
            format!("ws://[{}]:{}", self.host, self.port)
        } else {
            format!("ws://{}:{}", self.host, self.port)
        }
    }

    /// Connected clients.
    pub fn clients(&self) -> usize {
        self.lock().server.as_ref().map_or(0, |s| s.client_count())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic while holding the lock leaves plain data behind: keep serving.
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Declares a channel (once per topic; later declarations of the same topic reuse it).
    pub(crate) fn channel(
        &self,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema: &[u8],
        message_encoding: &str,
    ) -> Result<Arc<RawChannel>> {
        let mut inner = self.lock();
        if let Some(c) = inner.channels.get(topic) {
            return Ok(c.clone());
        }
        let channel = ChannelBuilder::new(topic)
            .message_encoding(message_encoding)
            .schema(Schema::new(schema_name, schema_encoding, schema.to_vec()))
            .context(&inner.context)
            .build_raw()
            .with_context(|| format!("live view: cannot declare {topic}"))?;
        inner.channels.insert(topic.to_owned(), channel.clone());
        Ok(channel)
    }

    /// Sends one message on `channel` to the subscribed clients; keeps the latest message of the
    /// latched topics for the thread that sends them again.
    pub(crate) fn publish(&self, channel: &RawChannel, log_time: u64, data: &[u8]) {
        channel.log_with_meta(data, PartialMetadata::with_log_time(log_time));
        let mut inner = self.lock();
        inner.last_time = log_time;
        let topic = channel.topic();
        if LATCHED.contains(&topic) {
            let msg = inner.latched.entry(topic.to_owned()).or_default();
            msg.clear();
            msg.extend_from_slice(data);
        }
    }
}
