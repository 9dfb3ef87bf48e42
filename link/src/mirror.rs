//! `cosim-link import NAME`, on a controller's host: the server's services
//! created here, as the server creates them (`serve::services`), and fed
//! from the exporter over Zenoh, so that a controller (Rust, Python, any
//! client of docs/protocol.md) runs unchanged, as if the server were local.

use crate::export::Hello;
use crate::message::{self, Message};
use crate::session::{self, local_err, zenoh_err, Endpoints, Keys, LinkError};
use cosim_server::serve::services::{Request, Services};
use cosim_shared::wire::*;
use iceoryx2::prelude::*;
use std::collections::HashMap;
use std::sync::mpsc::channel;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// How `import` runs.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    pub name: String,
    pub endpoints: Endpoints,
    /// How long to wait for the exporter's hello.
    pub patience: Duration,
}

/// iceoryx2's ports locked for use from Zenoh's threads: a frame is
/// published from the callback that receives it.
type Ts = ipc_threadsafe::Service;

/// How often the local clients are checked for a departure (as the
/// server checks a controller it waits for).
const CLIENT_CHECK: Duration = Duration::from_millis(10);

/// How often the local clients' nodes are looked up alive (a killed
/// process leaves its ports behind a dead node).
const LIVENESS_CHECK: Duration = Duration::from_millis(50);

/// The mirror once its services exist, and the frames that came before.
#[derive(Default)]
struct Shared {
    mirror: Option<Mirror>,
    early: Vec<Vec<u8>>,
}

/// Runs the importing half until the exporter is gone; `ready` is told
/// when the local services exist.
pub fn import(opts: &ImportOptions, ready: impl FnOnce()) -> Result<(), LinkError> {
    let keys = Keys::new(&opts.name)?;
    let z = session::open(&opts.endpoints)?;
    let zid = z.zid().to_string();
    let shared = Arc::new(Mutex::new(Shared::default()));
    let (gone_tx, gone) = channel::<()>();

    let on_state = shared.clone();
    let _state = z
        .declare_subscriber(keys.state())
        .callback(move |sample| {
            let Ok(mut s) = on_state.lock() else {
                return;
            };
            let bytes = sample.payload().to_bytes();
            match s.mirror.as_mut() {
                Some(m) => {
                    if let Err(e) = m.publish(&bytes).and_then(|()| m.catch_answers()) {
                        tracing::warn!("{e}");
                    }
                }
                None => s.early.push(bytes.into_owned()),
            }
        })
        .wait()
        .map_err(zenoh_err("cannot subscribe to the frames"))?;
    let on_down = shared.clone();
    let _down = z
        .declare_subscriber(keys.down(&zid))
        .callback(move |sample| {
            let Some(m) = Message::decode(&sample.payload().to_bytes()) else {
                tracing::warn!("a message from the exporter that is not one; ignored");
                return;
            };
            if let Ok(mut s) = on_down.lock() {
                if let Some(mirror) = s.mirror.as_mut() {
                    mirror.answer(m);
                }
            }
        })
        .wait()
        .map_err(zenoh_err("cannot subscribe to the responses"))?;
    let _exporter = z
        .liveliness()
        .declare_subscriber(keys.exporter())
        .callback(move |sample| {
            if sample.kind() == zenoh::sample::SampleKind::Delete {
                let _ = gone_tx.send(());
            }
        })
        .wait()
        .map_err(zenoh_err("cannot watch the exporter's liveliness"))?;

    let hello = hello(&z, &keys, opts)?;
    let svc = Services::<Ts>::create(&opts.name, false, hello.frame_words as usize)
        .map_err(local_err("cannot create the mirror's services"))?;
    let (_wake_node, wake) = wake_listener(&opts.name)?;
    let _token = z
        .liveliness()
        .declare_token(keys.importer(&zid))
        .wait()
        .map_err(zenoh_err("cannot declare the liveliness token"))?;
    let up = z
        .declare_publisher(keys.up(&zid))
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .priority(zenoh::qos::Priority::RealTime)
        .express(true)
        .wait()
        .map_err(zenoh_err("cannot declare the publisher of inputs"))?;
    {
        let mut s = shared
            .lock()
            .map_err(|_| local_err::<&str>("the mirror")("poisoned"))?;
        let mut mirror = Mirror {
            svc,
            last_sequence: 0,
            requests: HashMap::new(),
            next_seq: 1,
            clients: Vec::new(),
            nodes: Vec::new(),
            words: Vec::new(),
            pid: u64::from(std::process::id()),
            up,
            spin: cosim_client::SpinRule::default(),
        };
        // The hello's frame, then what came since, oldest first (a frame
        // already published is not published again).
        for bytes in std::iter::once(hello.last).chain(std::mem::take(&mut s.early)) {
            if !bytes.is_empty() {
                mirror.publish(&bytes)?;
            }
        }
        s.mirror = Some(mirror);
    }
    ready();
    tracing::info!("importing server '{}' (importer {zid})", opts.name);
    let result = forward(&shared, &wake, &gone);
    if let Ok(mut s) = shared.lock() {
        s.mirror = None;
    }
    let _ = z.close().wait();
    result
}

/// The local clients' inputs and requests sent to the exporter as each
/// wakes the mirror (and every [`CLIENT_CHECK`], when their departures are
/// looked for), until the exporter is gone.
fn forward(
    shared: &Mutex<Shared>,
    wake: &iceoryx2::port::listener::Listener<ipc::Service>,
    gone: &std::sync::mpsc::Receiver<()>,
) -> Result<(), LinkError> {
    let mut next_check = Instant::now() + CLIENT_CHECK;
    let mut next_liveness = Instant::now() + LIVENESS_CHECK;
    let lock = || {
        shared
            .lock()
            .map_err(|_| local_err::<&str>("the mirror")("poisoned"))
    };
    let mut dead = Vec::new();
    loop {
        match wake.timed_wait(|_| {}, CLIENT_CHECK) {
            Ok(_) | Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => {}
            Err(e) => return Err(local_err("cannot wait for wake-ups")(e)),
        }
        if gone.try_recv().is_ok() {
            tracing::info!("the exporter is gone");
            return Ok(());
        }
        let now = Instant::now();
        let looked = now >= next_liveness;
        dead.clear();
        if looked {
            // The node list is read without the lock: it takes long enough
            // to hold up a frame.
            next_liveness = now + LIVENESS_CHECK;
            let clients: Vec<u128> = match lock()?.mirror.as_ref() {
                Some(m) => m.clients.iter().map(|&(c, _)| c).collect(),
                None => return Ok(()),
            };
            dead.extend(
                clients
                    .into_iter()
                    .filter(|&c| cosim_client::node_alive(c) == Some(false)),
            );
        }
        let mut s = lock()?;
        let Some(mirror) = s.mirror.as_mut() else {
            return Ok(());
        };
        mirror.forward()?;
        if now >= next_check || looked {
            next_check = now + CLIENT_CHECK;
            mirror.check_clients(looked.then_some(&dead[..]))?;
        }
    }
}

/// A listener of the local clients' wake-ups of its own, so that the
/// wait holds no lock the frames' callback needs.
fn wake_listener(
    name: &str,
) -> Result<
    (
        Node<ipc::Service>,
        iceoryx2::port::listener::Listener<ipc::Service>,
    ),
    LinkError,
> {
    let node = cosim_client::domain::node()
        .map_err(local_err("cannot read the domain"))?
        .create::<ipc::Service>()
        .map_err(local_err("cannot create a node"))?;
    let service = services::wake(name);
    let name: ServiceName = service
        .as_str()
        .try_into()
        .map_err(local_err(format!("service name {service}")))?;
    let listener = node
        .service_builder(&name)
        .event()
        .open()
        .map_err(local_err(format!("cannot open {service}")))?
        .listener_builder()
        .create()
        .map_err(local_err("cannot listen for wake-ups"))?;
    Ok((node, listener))
}

/// The exporter's hello, asked until it answers or `opts.patience` ends.
fn hello(z: &zenoh::Session, keys: &Keys, opts: &ImportOptions) -> Result<Hello, LinkError> {
    let start = Instant::now();
    loop {
        let replies = z
            .get(keys.hello())
            .timeout(Duration::from_millis(500))
            .wait()
            .map_err(zenoh_err("cannot ask for the exporter's hello"))?;
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                if let Some(h) = Hello::decode(&sample.payload().to_bytes()) {
                    return Ok(h);
                }
            }
        }
        if start.elapsed() > opts.patience {
            return Err(LinkError::NoPeer {
                name: opts.name.clone(),
                waited_s: start.elapsed().as_secs_f64(),
            });
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The local services and what they hold between events.
struct Mirror {
    svc: Services<Ts>,
    /// The newest frame published (a frame is never published twice).
    last_sequence: u64,
    /// Requests out at the exporter: their local client and request.
    requests: HashMap<u64, (u128, Request<Ts>)>,
    next_seq: u64,
    /// Local clients known to the exporter, with the checks in a row
    /// that found them gone.
    clients: Vec<(u128, u32)>,
    nodes: Vec<u128>,
    words: Vec<u64>,
    /// This process's id, which the responses carry as the server's (a
    /// client looks for the server's node by it).
    pid: u64,
    /// To the exporter: inputs, requests, departures.
    up: zenoh::pubsub::Publisher<'static>,
    /// How long the frames' callback waits for the answer (below).
    spin: cosim_client::SpinRule,
}

impl Mirror {
    /// A frame from the exporter published here, unless it is one
    /// already published (the hello's frame comes again).
    fn publish(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let Some((header, rest)) = message::take_struct::<StateHeader>(bytes) else {
            tracing::warn!("a frame shorter than its header; dropped");
            return Ok(());
        };
        if header.sequence <= self.last_sequence && header.sequence != 0 {
            return Ok(());
        }
        if message::take_words(rest, &mut self.words).is_none() {
            tracing::warn!("a frame of broken words; dropped");
            return Ok(());
        }
        self.last_sequence = header.sequence;
        let words = &self.words;
        send_words(&self.svc.state, header, words.len(), |w| {
            for &x in words {
                w.put(x);
            }
        })
        .map_err(local_err("cannot publish a frame"))?;
        self.svc
            .state_ready
            .notify()
            .map_err(local_err("cannot notify the frame's readers"))?;
        Ok(())
    }

    /// A response passed to its local client, or its request let go.
    fn answer(&mut self, m: Message) {
        match m {
            Message::Response {
                seq, mut response, ..
            } => {
                if let Some((_, req)) = self.requests.get(&seq) {
                    response.pid = self.pid;
                    if let Err(e) = req.send_copy(response) {
                        tracing::warn!("cannot pass a response on: {e:?}");
                    }
                }
            }
            Message::End { seq, .. } => {
                self.requests.remove(&seq);
            }
            _ => {}
        }
    }

    /// The local clients' inputs and requests sent to the exporter.
    fn forward(&mut self) -> Result<usize, LinkError> {
        let mut sent = 0;
        let put = |up: &zenoh::pubsub::Publisher<'static>, m: Message| {
            up.put(m.encode())
                .wait()
                .map_err(zenoh_err("cannot send to the exporter"))
        };
        while let Some(sample) = self
            .svc
            .input
            .receive()
            .map_err(local_err("cannot receive inputs"))?
        {
            let Some(client) = self.svc.publisher_node(sample.origin().value()) else {
                tracing::warn!("an input whose publisher is gone; dropped");
                continue;
            };
            self.known(client);
            let bytes = message::input_bytes(sample.user_header(), sample.payload());
            put(&self.up, Message::Input { client, bytes })?;
            sent += 1;
        }
        while let Some(req) = self
            .svc
            .receive_request()
            .map_err(local_err("cannot receive requests"))?
        {
            // A client whose port is gone before its request is read has
            // no one to answer: the server refuses such a join, and so
            // does the exporter's proxy, which never sees it.
            let Some(client) = self.svc.request_node(&req) else {
                continue;
            };
            self.known(client);
            let seq = self.next_seq;
            self.next_seq += 1;
            let request = *req.payload();
            self.requests.insert(seq, (client, req));
            put(
                &self.up,
                Message::Request {
                    client,
                    seq,
                    request,
                },
            )?;
            sent += 1;
        }
        Ok(sent)
    }

    /// After a frame: the controllers' answers come within microseconds
    /// when they have cores, so the callback that published it polls for
    /// them a while (the hybrid wait's rule, `SpinRule`: at most twice
    /// what the answers have taken, and not at all for a while after a
    /// spin that failed) and sends them on from Zenoh's thread, sparing
    /// the forwarding thread's wake-up on the lockstep's path.
    fn catch_answers(&mut self) -> Result<(), LinkError> {
        let budget = self.spin.budget();
        if budget.is_zero() {
            return Ok(());
        }
        let start = Instant::now();
        let until = start + budget;
        let mut last = start;
        loop {
            if self.forward()? > 0 {
                self.spin.finished(start.elapsed(), true);
                return Ok(());
            }
            let now = Instant::now();
            if !self.spin.keep_spinning(true, last, now, until) {
                return Ok(());
            }
            last = now;
            std::hint::spin_loop();
        }
    }

    fn known(&mut self, client: u128) {
        if !self.clients.iter().any(|&(c, _)| c == client) {
            self.clients.push((client, 0));
        }
    }

    /// A local client whose ports are gone, or whose node is `dead` (when
    /// the nodes were looked up), in two checks in a row is told gone to the exporter, which lets its proxy
    /// go: the server then sees the proxy's ports go, as a local client's.
    fn check_clients(&mut self, dead: Option<&[u128]>) -> Result<(), LinkError> {
        if self.clients.is_empty() {
            return Ok(());
        }
        self.svc.client_nodes(&mut self.nodes);
        let nodes = &self.nodes;
        let mut gone = Vec::new();
        for (client, misses) in self.clients.iter_mut() {
            // Between node lookups a client with its ports keeps its count.
            match (nodes.binary_search(client).is_ok(), dead) {
                (false, _) => *misses += 1,
                (true, Some(d)) if d.contains(client) => *misses += 1,
                (true, Some(_)) => *misses = 0,
                (true, None) => {}
            }
            if *misses >= 2 {
                gone.push(*client);
            }
        }
        for client in gone {
            self.clients.retain(|&(c, _)| c != client);
            self.requests.retain(|_, (c, _)| *c != client);
            self.up
                .put(Message::Gone { client }.encode())
                .wait()
                .map_err(zenoh_err("cannot send to the exporter"))?;
            tracing::info!("local client {client:032x} is gone");
        }
        Ok(())
    }
}
