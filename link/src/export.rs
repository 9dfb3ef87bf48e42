//! `cosim-link export NAME`, on the server's host: the server's frames
//! published over Zenoh, and each remote client played by a proxy of its
//! own here (an iceoryx2 node with a control client, an input publisher
//! and a wake notifier), so that the server binds a remote controller's
//! slot, checks its inputs' sender and notices its departure exactly as
//! for a local process.

use crate::message::{self, Message};
use crate::session::{self, local_err, zenoh_err, Endpoints, Keys, LinkError};
use cosim_client::{Connection, Monitor};
use cosim_shared::wire::*;
use iceoryx2::prelude::*;
use std::collections::HashMap;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;

/// iceoryx2's ports locked for use from Zenoh's threads: a remote input
/// is published to the server from the callback that receives it.
type Ts = ipc_threadsafe::Service;
type Pending =
    iceoryx2::pending_response::PendingResponse<Ts, ControlRequest, (), ControlResponse, ()>;
type InputPublisher = iceoryx2::port::publisher::Publisher<Ts, [u64], InputHeader>;

/// How `export` runs.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    pub name: String,
    pub endpoints: Endpoints,
    /// How long to wait for the server to come up.
    pub patience: Duration,
}

/// What the exporter tells an importer first: the frames' largest size
/// (for the importer's services) and the newest frame.
#[derive(Debug, Default)]
pub(crate) struct Hello {
    pub frame_words: u64,
    pub last: Vec<u8>,
}

impl Hello {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.frame_words.to_le_bytes().to_vec();
        out.extend_from_slice(&self.last);
        out
    }
    pub fn decode(bytes: &[u8]) -> Option<Hello> {
        let frame_words = u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?);
        Some(Hello {
            frame_words,
            last: bytes[8..].to_vec(),
        })
    }
}

/// The most payload words a frame of a scene with these counts can have:
/// bodies, joints and the contacts a frame carries at most
/// (docs/protocol.md, `contacts_carried`).
pub fn frame_words(bodies: u32, joints: u32) -> u64 {
    let b = u64::from(bodies);
    13 * b + 5 * u64::from(joints) + 8 * (4 * b + 64)
}

fn service<T>(
    node: &Node<Ts>,
    service: &str,
    open: impl FnOnce(iceoryx2::service::builder::Builder<Ts>) -> Result<T, LinkError>,
) -> Result<T, LinkError> {
    let name: ServiceName = service
        .try_into()
        .map_err(local_err(format!("service name {service}")))?;
    open(node.service_builder(&name))
}

/// One remote client's stand-in on the server's host: a node of its own,
/// so that the server binds the client's slot to it.
struct Proxy {
    node: Node<Ts>,
    control: iceoryx2::port::client::Client<Ts, ControlRequest, (), ControlResponse, ()>,
    wake: iceoryx2::port::notifier::Notifier<Ts>,
    input: Option<InputPublisher>,
    pending: Vec<(u64, Pending)>,
}

impl Proxy {
    fn open(name: &str) -> Result<Proxy, LinkError> {
        let node = cosim_client::domain::node()
            .map_err(local_err("cannot read the domain"))?
            .create::<Ts>()
            .map_err(local_err("cannot create a proxy's node"))?;
        let control = service(&node, &services::control(name), |b| {
            b.request_response::<ControlRequest, ControlResponse>()
                .open()
                .map_err(local_err("cannot open the server's control service"))?
                .client_builder()
                .create()
                .map_err(local_err("cannot create a control client"))
        })?;
        let wake = service(&node, &services::wake(name), |b| {
            b.event()
                .open()
                .map_err(local_err("cannot open the server's wake-up event"))?
                .notifier_builder()
                .create()
                .map_err(local_err("cannot create a notifier"))
        })?;
        Ok(Proxy {
            node,
            control,
            wake,
            input: None,
            pending: Vec::new(),
        })
    }

    /// The input publisher, created before a join is forwarded (the server
    /// binds a slot to the publisher of the node that joins) or at the
    /// first input.
    fn input(&mut self, name: &str) -> Result<&InputPublisher, LinkError> {
        if self.input.is_none() {
            let publisher = service(&self.node, &services::input(name), |b| {
                b.publish_subscribe::<[u64]>()
                    .user_header::<InputHeader>()
                    .open()
                    .map_err(local_err("cannot open the server's inputs"))?
                    .publisher_builder()
                    .initial_max_slice_len(64)
                    .allocation_strategy(AllocationStrategy::PowerOfTwo)
                    .create()
                    .map_err(local_err("cannot publish inputs"))
            })?;
            self.input = Some(publisher);
        }
        self.input
            .as_ref()
            .ok_or_else(|| local_err::<&str>("no input publisher")("unreachable"))
    }

    /// An input's header and words published, then the server woken.
    fn send_input(&mut self, name: &str, bytes: &[u8], words: &mut Vec<u64>) -> Result<(), String> {
        let (header, rest) =
            message::take_struct::<InputHeader>(bytes).ok_or("shorter than its header")?;
        message::take_words(rest, words).ok_or("not whole words")?;
        let publisher = self.input(name).map_err(|e| e.to_string())?;
        send_words(publisher, header, words.len(), |w| {
            for &x in words.iter() {
                w.put(x);
            }
        })
        .map_err(|e| format!("{e:?}"))?;
        let _ = self.wake.notify();
        Ok(())
    }
}

/// The proxies and the publishers of responses, shared by Zenoh's
/// callbacks and the loop that collects responses.
struct Proxies {
    name: String,
    keys: Keys,
    session: zenoh::Session,
    by_client: HashMap<(String, u128), Proxy>,
    downs: HashMap<String, zenoh::pubsub::Publisher<'static>>,
    words: Vec<u64>,
}

impl Proxies {
    /// What importer `zid` sent, done; true when a request is now out.
    fn take(&mut self, zid: &str, m: Message) -> Result<bool, LinkError> {
        let key = (zid.to_string(), m.client());
        if let Message::Gone { client } = m {
            if self.by_client.remove(&key).is_some() {
                tracing::info!("client {client:032x} of importer {zid} is gone");
            }
            return Ok(false);
        }
        if !self.by_client.contains_key(&key) {
            self.by_client.insert(key.clone(), Proxy::open(&self.name)?);
        }
        let Some(proxy) = self.by_client.get_mut(&key) else {
            return Ok(false);
        };
        match m {
            Message::Input { bytes, .. } => {
                if let Err(e) = proxy.send_input(&self.name, &bytes, &mut self.words) {
                    tracing::warn!("an input of importer {zid} not forwarded: {e}");
                }
                Ok(false)
            }
            Message::Request { seq, request, .. } => {
                if request.command == CMD_JOIN {
                    proxy.input(&self.name)?;
                }
                match proxy.control.send_copy(request) {
                    Ok(p) => {
                        proxy.pending.push((seq, p));
                        let _ = proxy.wake.notify();
                        Ok(true)
                    }
                    Err(e) => {
                        tracing::warn!("a request not forwarded: {e:?}");
                        let end = Message::End { client: key.1, seq };
                        self.down(zid)?
                            .put(end.encode())
                            .wait()
                            .map_err(zenoh_err("cannot answer an importer"))?;
                        Ok(false)
                    }
                }
            }
            _ => Ok(false),
        }
    }

    /// Importer `zid` is gone: its proxies let go.
    fn importer_gone(&mut self, zid: &str) {
        let before = self.by_client.len();
        self.by_client.retain(|(z, _), _| z != zid);
        self.downs.remove(zid);
        tracing::info!(
            "importer {zid} is gone: {} of its clients let go",
            before - self.by_client.len()
        );
    }

    /// Importer `zid`'s publisher of responses.
    fn down(&mut self, zid: &str) -> Result<&zenoh::pubsub::Publisher<'static>, LinkError> {
        if !self.downs.contains_key(zid) {
            let p = self
                .session
                .declare_publisher(self.keys.down(zid))
                .congestion_control(zenoh::qos::CongestionControl::Block)
                .priority(zenoh::qos::Priority::RealTime)
                .express(true)
                .wait()
                .map_err(zenoh_err("cannot declare a response publisher"))?;
            self.downs.insert(zid.to_string(), p);
        }
        self.downs
            .get(zid)
            .ok_or_else(|| local_err::<&str>("response publisher")("missing"))
    }

    /// The responses that arrived sent on; true while requests are out.
    fn collect(&mut self) -> Result<bool, LinkError> {
        let mut out = Vec::new();
        for ((zid, client), proxy) in self.by_client.iter_mut() {
            proxy.pending.retain(|(seq, pending)| {
                // NOTE: whether the server still holds the request is read
                // before draining, as the client library does: a response
                // sent just before the request is let go is then drained.
                let connected =
                    pending.is_connected() && pending.number_of_server_connections() > 0;
                loop {
                    match pending.receive() {
                        Ok(Some(r)) => out.push((
                            zid.clone(),
                            Message::Response {
                                client: *client,
                                seq: *seq,
                                response: *r.payload(),
                            },
                        )),
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("cannot receive a response: {e:?}");
                            break;
                        }
                    }
                }
                if !connected {
                    let end = Message::End {
                        client: *client,
                        seq: *seq,
                    };
                    out.push((zid.clone(), end));
                }
                connected
            });
        }
        for (zid, m) in out {
            self.down(&zid)?
                .put(m.encode())
                .wait()
                .map_err(zenoh_err("cannot answer an importer"))?;
        }
        Ok(self.by_client.values().any(|p| !p.pending.is_empty()))
    }
}

/// What wakes the loop that collects responses.
enum Event {
    Requested,
    ServerGone,
}

/// Runs the exporting half until the server is gone; `listening` is told
/// the endpoints importers can connect to once they are up.
pub fn export(opts: &ExportOptions, listening: impl FnOnce(&[String])) -> Result<(), LinkError> {
    let keys = Keys::new(&opts.name)?;
    let conn = cosim_client::when_up(opts.patience, || Connection::connect(&opts.name))
        .map_err(local_err(format!("no server named '{}'", opts.name)))?;
    let info = conn.info().map_err(local_err("the server's info"))?;
    let hello = Arc::new(Mutex::new(Hello {
        frame_words: frame_words(info.body_count, info.joint_count),
        last: Vec::new(),
    }));
    let z = session::open(&opts.endpoints)?;
    let _token = z
        .liveliness()
        .declare_token(keys.exporter())
        .wait()
        .map_err(zenoh_err("cannot declare the liveliness token"))?;
    let (tx, rx) = channel::<Event>();
    let proxies = Arc::new(Mutex::new(Proxies {
        name: opts.name.clone(),
        keys: keys.clone(),
        session: z.clone(),
        by_client: HashMap::new(),
        downs: HashMap::new(),
        words: Vec::new(),
    }));

    let told = hello.clone();
    let _hello = z
        .declare_queryable(keys.hello())
        .callback(move |query| {
            let bytes = match told.lock() {
                Ok(h) => h.encode(),
                Err(_) => return,
            };
            let _ = query.reply(query.key_expr().clone(), bytes).wait();
        })
        .wait()
        .map_err(zenoh_err("cannot declare the hello queryable"))?;

    // Inputs go to the server from Zenoh's receiving thread: no hand-over
    // to another thread on the lockstep's path.
    let (up_tx, up_keys, up_proxies) = (tx.clone(), keys.clone(), proxies.clone());
    let _up = z
        .declare_subscriber(keys.up_all())
        .callback(move |sample| {
            let Some(zid) = up_keys.up_of(sample.key_expr().as_str()) else {
                return;
            };
            let Some(m) = Message::decode(&sample.payload().to_bytes()) else {
                tracing::warn!("a message from importer {zid} that is not one; ignored");
                return;
            };
            let Ok(mut p) = up_proxies.lock() else {
                return;
            };
            match p.take(zid, m) {
                Ok(true) => {
                    let _ = up_tx.send(Event::Requested);
                }
                Ok(false) => {}
                Err(e) => tracing::warn!("importer {zid}: {e}"),
            }
        })
        .wait()
        .map_err(zenoh_err("cannot subscribe to the importers"))?;

    let (gone_keys, gone_proxies) = (keys.clone(), proxies.clone());
    let _importers = z
        .liveliness()
        .declare_subscriber(keys.importer_all())
        .callback(move |sample| {
            if sample.kind() == zenoh::sample::SampleKind::Delete {
                if let Some(zid) = gone_keys.importer_of(sample.key_expr().as_str()) {
                    if let Ok(mut p) = gone_proxies.lock() {
                        p.importer_gone(zid);
                    }
                }
            }
        })
        .wait()
        .map_err(zenoh_err("cannot watch the importers' liveliness"))?;

    let states = {
        let (z, keys, name, hello) = (z.clone(), keys.clone(), opts.name.clone(), hello.clone());
        std::thread::spawn(move || {
            let r = forward_states(&z, &keys, &name, &hello);
            let _ = tx.send(Event::ServerGone);
            r
        })
    };
    listening(&session::listening(&opts.endpoints));
    tracing::info!("exporting server '{}'", opts.name);
    let served = collect_responses(&proxies, &rx);
    drop(conn);
    let forwarded = states
        .join()
        .map_err(|_| local_err::<&str>("the state thread")("panicked"))?;
    if let Ok(mut p) = proxies.lock() {
        p.by_client.clear();
    }
    let _ = z.close().wait();
    served.and(forwarded)
}

/// The server's responses sent to the importers while requests are out,
/// until the server is gone.
fn collect_responses(proxies: &Mutex<Proxies>, rx: &Receiver<Event>) -> Result<(), LinkError> {
    let mut out = false;
    loop {
        let event = if out {
            // A request is answered within microseconds: poll until done.
            std::thread::sleep(Duration::from_micros(20));
            rx.try_recv().map_err(|e| match e {
                TryRecvError::Empty => RecvTimeoutError::Timeout,
                TryRecvError::Disconnected => RecvTimeoutError::Disconnected,
            })
        } else {
            rx.recv_timeout(Duration::from_millis(200))
        };
        match event {
            Ok(Event::ServerGone) | Err(RecvTimeoutError::Disconnected) => return Ok(()),
            Ok(Event::Requested) | Err(RecvTimeoutError::Timeout) => {}
        }
        out = match proxies.lock() {
            Ok(mut p) => p.collect()?,
            Err(_) => return Err(local_err::<&str>("the proxies")("poisoned")),
        };
    }
}

/// Every frame of the server, in order, published to the importers; ends
/// when the server is gone (a shutdown frame is forwarded first).
fn forward_states(
    z: &zenoh::Session,
    keys: &Keys,
    name: &str,
    hello: &Mutex<Hello>,
) -> Result<(), LinkError> {
    let publisher = z
        .declare_publisher(keys.state())
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .priority(zenoh::qos::Priority::RealTime)
        .express(true)
        .wait()
        .map_err(zenoh_err("cannot declare the state publisher"))?;
    let monitor = Monitor::open(name, services::MAX_STATE_BUFFER)
        .map_err(local_err("cannot subscribe to the state"))?;
    let mut words = Vec::new();
    loop {
        let frame = match monitor.next(Duration::from_secs(1)) {
            Ok(f) => f,
            Err(cosim_client::ClientError::Timeout { .. }) => continue,
            Err(e) => {
                tracing::info!("the server is gone: {e}");
                return Ok(());
            }
        };
        words.clear();
        frame.encode(&mut words);
        let bytes = message::state_bytes(&frame.header(), &words);
        if let Ok(mut h) = hello.lock() {
            h.last.clone_from(&bytes);
        }
        publisher
            .put(bytes)
            .wait()
            .map_err(zenoh_err("cannot publish a state frame"))?;
    }
}
