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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::sync::Arc;
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

/// What reaches the mirror's loop.
enum Event {
    /// A state frame's bytes.
    State(Vec<u8>),
    /// A response or the end of a request.
    Down(Box<Message>),
    /// A local client notified `wake` (an input or a request).
    Woken,
    /// The exporter's liveliness token went (it ended, or its host is
    /// unreachable past Zenoh's lease).
    ExporterGone,
}

/// How often the local clients are checked for a departure (as the
/// server checks a controller it waits for).
const CLIENT_CHECK: Duration = Duration::from_millis(10);

/// Runs the importing half until the exporter is gone; `ready` is told
/// when the local services exist.
pub fn import(opts: &ImportOptions, ready: impl FnOnce()) -> Result<(), LinkError> {
    let keys = Keys::new(&opts.name)?;
    let z = session::open(&opts.endpoints)?;
    let zid = z.zid().to_string();
    let (tx, rx) = channel::<Event>();

    let state_tx = tx.clone();
    let _state = z
        .declare_subscriber(keys.state())
        .callback(move |sample| {
            let _ = state_tx.send(Event::State(sample.payload().to_bytes().into_owned()));
        })
        .wait()
        .map_err(zenoh_err("cannot subscribe to the frames"))?;
    let down_tx = tx.clone();
    let _down = z
        .declare_subscriber(keys.down(&zid))
        .callback(
            move |sample| match Message::decode(&sample.payload().to_bytes()) {
                Some(m) => {
                    let _ = down_tx.send(Event::Down(Box::new(m)));
                }
                None => tracing::warn!("a message from the exporter that is not one; ignored"),
            },
        )
        .wait()
        .map_err(zenoh_err("cannot subscribe to the responses"))?;
    let gone_tx = tx.clone();
    let _exporter = z
        .liveliness()
        .declare_subscriber(keys.exporter())
        .callback(move |sample| {
            if sample.kind() == zenoh::sample::SampleKind::Delete {
                let _ = gone_tx.send(Event::ExporterGone);
            }
        })
        .wait()
        .map_err(zenoh_err("cannot watch the exporter's liveliness"))?;

    let hello = hello(&z, &keys, opts)?;
    let svc = Services::create(&opts.name, false, hello.frame_words as usize)
        .map_err(local_err("cannot create the mirror's services"))?;
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

    let stop = Arc::new(AtomicBool::new(false));
    let waker = {
        let (name, stop, tx) = (opts.name.clone(), stop.clone(), tx.clone());
        std::thread::spawn(move || wakes(&name, &stop, &tx))
    };
    let mut mirror = Mirror {
        svc,
        last_sequence: 0,
        requests: HashMap::new(),
        next_seq: 1,
        clients: Vec::new(),
        nodes: Vec::new(),
        words: Vec::new(),
        pid: u64::from(std::process::id()),
    };
    if !hello.last.is_empty() {
        mirror.publish(&hello.last)?;
    }
    ready();
    tracing::info!("importing server '{}' (importer {zid})", opts.name);
    let result = mirror.run(&up, &rx);
    stop.store(true, Ordering::Relaxed);
    let _ = waker.join();
    drop(mirror);
    let _ = z.close().wait();
    result
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

/// The local clients' wake-ups, passed to the mirror's loop: it waits on
/// one channel for them and for what Zenoh delivers.
fn wakes(name: &str, stop: &AtomicBool, tx: &Sender<Event>) -> Result<(), LinkError> {
    let node = cosim_client::domain::node()
        .map_err(local_err("cannot read the domain"))?
        .create::<ipc::Service>()
        .map_err(local_err("cannot create a node"))?;
    let service = services::wake(name);
    let listener = node
        .service_builder(
            &service
                .as_str()
                .try_into()
                .map_err(local_err(format!("service name {service}")))?,
        )
        .event()
        .open()
        .map_err(local_err(format!("cannot open {service}")))?
        .listener_builder()
        .create()
        .map_err(local_err("cannot listen for wake-ups"))?;
    while !stop.load(Ordering::Relaxed) {
        let mut woken = false;
        match listener.timed_wait(|_| woken = true, Duration::from_millis(100)) {
            Ok(_) => {}
            Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => {}
            Err(e) => return Err(local_err("cannot wait for wake-ups")(e)),
        }
        if woken && tx.send(Event::Woken).is_err() {
            break;
        }
    }
    Ok(())
}

/// The local services and what they hold between events.
struct Mirror {
    svc: Services,
    /// The newest frame published (a frame is never published twice).
    last_sequence: u64,
    /// Requests out at the exporter: their local client and request.
    requests: HashMap<u64, (u128, Request)>,
    next_seq: u64,
    /// Local clients known to the exporter, with the checks in a row
    /// that found them gone.
    clients: Vec<(u128, u32)>,
    nodes: Vec<u128>,
    words: Vec<u64>,
    /// This process's id, which the responses carry as the server's (a
    /// client looks for the server's node by it).
    pid: u64,
}

impl Mirror {
    fn run(
        &mut self,
        up: &zenoh::pubsub::Publisher<'_>,
        rx: &std::sync::mpsc::Receiver<Event>,
    ) -> Result<(), LinkError> {
        let mut next_check = Instant::now() + CLIENT_CHECK;
        loop {
            let event = rx.recv_timeout(CLIENT_CHECK);
            match event {
                Ok(Event::State(bytes)) => self.publish(&bytes)?,
                Ok(Event::Down(m)) => self.answer(*m),
                Ok(Event::ExporterGone) => {
                    tracing::info!("the exporter is gone");
                    return Ok(());
                }
                Ok(Event::Woken) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Ok(()),
            }
            self.forward(up)?;
            if Instant::now() >= next_check {
                next_check = Instant::now() + CLIENT_CHECK;
                self.check_clients(up)?;
            }
        }
    }

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
    fn forward(&mut self, up: &zenoh::pubsub::Publisher<'_>) -> Result<(), LinkError> {
        let put = |m: Message| {
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
            put(Message::Input { client, bytes })?;
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
            put(Message::Request {
                client,
                seq,
                request,
            })?;
        }
        Ok(())
    }

    fn known(&mut self, client: u128) {
        if !self.clients.iter().any(|&(c, _)| c == client) {
            self.clients.push((client, 0));
        }
    }

    /// A local client whose ports are gone, or whose node is dead, in two
    /// checks in a row is told gone to the exporter, which lets its proxy
    /// go: the server then sees the proxy's ports go, as a local client's.
    fn check_clients(&mut self, up: &zenoh::pubsub::Publisher<'_>) -> Result<(), LinkError> {
        if self.clients.is_empty() {
            return Ok(());
        }
        self.svc.client_nodes(&mut self.nodes);
        let nodes = &self.nodes;
        let mut gone = Vec::new();
        for (client, misses) in self.clients.iter_mut() {
            let here = nodes.binary_search(client).is_ok()
                && cosim_client::node_alive(*client) != Some(false);
            *misses = if here { 0 } else { *misses + 1 };
            if *misses >= 2 {
                gone.push(*client);
            }
        }
        for client in gone {
            self.clients.retain(|&(c, _)| c != client);
            self.requests.retain(|_, (c, _)| *c != client);
            up.put(Message::Gone { client }.encode())
                .wait()
                .map_err(zenoh_err("cannot send to the exporter"))?;
            tracing::info!("local client {client:032x} is gone");
        }
        Ok(())
    }
}
