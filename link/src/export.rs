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
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;

type Pending = iceoryx2::pending_response::PendingResponse<
    ipc::Service,
    ControlRequest,
    (),
    ControlResponse,
    (),
>;
type InputPublisher = iceoryx2::port::publisher::Publisher<ipc::Service, [u64], InputHeader>;

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

/// What reaches the exporter's loop.
enum Event {
    Up(String, Box<Message>),
    ImporterGone(String),
    ServerGone,
}

/// One remote client's stand-in on the server's host.
struct Proxy {
    conn: Connection,
    input: Option<InputPublisher>,
    pending: Vec<(u64, Pending)>,
}

impl Proxy {
    fn open(name: &str) -> Result<Proxy, LinkError> {
        let conn = Connection::connect(name).map_err(local_err("cannot reach the server"))?;
        Ok(Proxy {
            conn,
            input: None,
            pending: Vec::new(),
        })
    }

    /// The input publisher, created before a join is forwarded (the server
    /// binds a slot to the publisher of the node that joins) or at the
    /// first input.
    fn input(&mut self, name: &str) -> Result<&InputPublisher, LinkError> {
        if self.input.is_none() {
            let service = services::input(name);
            let publisher = self
                .conn
                .node()
                .service_builder(
                    &service
                        .as_str()
                        .try_into()
                        .map_err(local_err(format!("service name {service}")))?,
                )
                .publish_subscribe::<[u64]>()
                .user_header::<InputHeader>()
                .open()
                .map_err(local_err(format!("cannot open {service}")))?
                .publisher_builder()
                .initial_max_slice_len(64)
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .create()
                .map_err(local_err("cannot publish inputs"))?;
            self.input = Some(publisher);
        }
        self.input
            .as_ref()
            .ok_or_else(|| local_err::<&str>("no input publisher")("unreachable"))
    }
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

    let up_tx = tx.clone();
    let up_keys = keys.clone();
    let _up = z
        .declare_subscriber(keys.up_all())
        .callback(move |sample| {
            let Some(zid) = up_keys.up_of(sample.key_expr().as_str()) else {
                return;
            };
            match Message::decode(&sample.payload().to_bytes()) {
                Some(m) => {
                    let _ = up_tx.send(Event::Up(zid.to_string(), Box::new(m)));
                }
                None => tracing::warn!("a message from importer {zid} that is not one; ignored"),
            }
        })
        .wait()
        .map_err(zenoh_err("cannot subscribe to the importers"))?;

    let gone_tx = tx.clone();
    let gone_keys = keys.clone();
    let _importers = z
        .liveliness()
        .declare_subscriber(keys.importer_all())
        .callback(move |sample| {
            if sample.kind() == zenoh::sample::SampleKind::Delete {
                if let Some(zid) = gone_keys.importer_of(sample.key_expr().as_str()) {
                    let _ = gone_tx.send(Event::ImporterGone(zid.to_string()));
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
    let served = serve_remote(&z, &keys, &opts.name, &rx);
    drop(conn);
    let forwarded = states
        .join()
        .map_err(|_| local_err::<&str>("the state thread")("panicked"))?;
    let _ = z.close().wait();
    served.and(forwarded)
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

/// The importers' inputs and requests played to the server by their
/// proxies, and the responses sent back, until the server is gone.
fn serve_remote(
    z: &zenoh::Session,
    keys: &Keys,
    name: &str,
    rx: &Receiver<Event>,
) -> Result<(), LinkError> {
    let mut proxies: HashMap<(String, u128), Proxy> = HashMap::new();
    let mut downs: HashMap<String, zenoh::pubsub::Publisher<'static>> = HashMap::new();
    let mut words = Vec::new();
    loop {
        // Responses are polled while requests are out; otherwise the loop
        // sleeps until an importer sends something.
        let waiting = proxies.values().any(|p| !p.pending.is_empty());
        let timeout = if waiting {
            Duration::from_micros(20)
        } else {
            Duration::from_millis(200)
        };
        match rx.recv_timeout(timeout) {
            Ok(Event::ServerGone) | Err(RecvTimeoutError::Disconnected) => return Ok(()),
            Ok(Event::ImporterGone(zid)) => {
                let before = proxies.len();
                proxies.retain(|(z, _), _| *z != zid);
                downs.remove(&zid);
                tracing::info!(
                    "importer {zid} is gone: {} of its clients let go",
                    before - proxies.len()
                );
            }
            Ok(Event::Up(zid, m)) if matches!(*m, Message::Gone { .. }) => {
                let client = m.client();
                if proxies.remove(&(zid.clone(), client)).is_some() {
                    tracing::info!("client {client:032x} of importer {zid} is gone");
                }
            }
            Ok(Event::Up(zid, m)) => {
                let key = (zid, m.client());
                if !proxies.contains_key(&key) {
                    proxies.insert(key.clone(), Proxy::open(name)?);
                }
                let Some(proxy) = proxies.get_mut(&key) else {
                    continue;
                };
                match *m {
                    Message::Input { bytes, .. } => {
                        if let Err(e) = send_input(proxy, name, &bytes, &mut words) {
                            tracing::warn!("an input of importer {} not forwarded: {e}", key.0);
                        }
                    }
                    Message::Request { seq, request, .. } => {
                        if request.command == CMD_JOIN {
                            proxy.input(name)?;
                        }
                        match proxy.conn.forward(request) {
                            Ok(p) => proxy.pending.push((seq, p)),
                            Err(e) => {
                                tracing::warn!("a request not forwarded: {e}");
                                down(z, keys, &mut downs, &key.0)?
                                    .put(Message::End { client: key.1, seq }.encode())
                                    .wait()
                                    .map_err(zenoh_err("cannot answer an importer"))?;
                            }
                        }
                    }
                    _ => {}
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
        }
        for ((zid, client), proxy) in proxies.iter_mut() {
            if proxy.pending.is_empty() {
                continue;
            }
            let publisher = down(z, keys, &mut downs, zid)?;
            let mut error = None;
            proxy.pending.retain(|(seq, pending)| {
                // NOTE: whether the server still holds the request is read
                // before draining, as the client library does: a response
                // sent just before the request is let go is then drained.
                let connected =
                    pending.is_connected() && pending.number_of_server_connections() > 0;
                loop {
                    match pending.receive() {
                        Ok(Some(r)) => {
                            let m = Message::Response {
                                client: *client,
                                seq: *seq,
                                response: *r.payload(),
                            };
                            if let Err(e) = publisher.put(m.encode()).wait() {
                                error = Some(e);
                            }
                        }
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("cannot receive a response: {e:?}");
                            break;
                        }
                    }
                }
                if connected {
                    return true;
                }
                let end = Message::End {
                    client: *client,
                    seq: *seq,
                };
                if let Err(e) = publisher.put(end.encode()).wait() {
                    error = Some(e);
                }
                false
            });
            if let Some(e) = error {
                return Err(zenoh_err("cannot answer an importer")(e));
            }
        }
    }
}

/// Importer `zid`'s publisher of responses.
fn down<'a>(
    z: &zenoh::Session,
    keys: &Keys,
    downs: &'a mut HashMap<String, zenoh::pubsub::Publisher<'static>>,
    zid: &str,
) -> Result<&'a zenoh::pubsub::Publisher<'static>, LinkError> {
    if !downs.contains_key(zid) {
        let p = z
            .declare_publisher(keys.down(zid))
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .priority(zenoh::qos::Priority::RealTime)
            .express(true)
            .wait()
            .map_err(zenoh_err("cannot declare a response publisher"))?;
        downs.insert(zid.to_string(), p);
    }
    downs
        .get(zid)
        .ok_or_else(|| local_err::<&str>("response publisher")("missing"))
}

/// An input's header and words published by the proxy, then the server
/// woken.
fn send_input(
    proxy: &mut Proxy,
    name: &str,
    bytes: &[u8],
    words: &mut Vec<u64>,
) -> Result<(), String> {
    let (header, rest) =
        message::take_struct::<InputHeader>(bytes).ok_or("shorter than its header")?;
    message::take_words(rest, words).ok_or("not whole words")?;
    let publisher = proxy.input(name).map_err(|e| e.to_string())?;
    send_words(publisher, header, words.len(), |w| {
        for &x in words.iter() {
            w.put(x);
        }
    })
    .map_err(|e| format!("{e:?}"))?;
    proxy.conn.wake_server();
    Ok(())
}
