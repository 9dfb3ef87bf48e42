//! The limits lockstep is measured against: a raw iceoryx2 ping-pong of
//! the same frames, and the same lockstep over a TCP socket.

use super::*;

pub(super) fn svc(name: &str) -> Result<ServiceName, BoxError> {
    Ok(name.try_into().map_err(|e| format!("{e:?}"))?)
}

pub(super) fn e<E: std::fmt::Debug>(e: E) -> BoxError {
    format!("{e:?}").into()
}

/// The four services of the raw ping-pong, opened (or created) alike by
/// both sides: states go out on `ping`, inputs come back on `pong`, so both
/// payload types cross, as in lockstep.
pub(super) struct PingPong {
    /// Owns the services; it lives as long as its ports.
    _node: Node<ipc::Service>,
    ping: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        ipc::Service,
        [u64],
        StateHeader,
    >,
    pong: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        ipc::Service,
        [u64],
        InputHeader,
    >,
    ping_ev: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    pong_ev: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
}

impl PingPong {
    fn open(base: &str) -> Result<PingPong, BoxError> {
        let node = NodeBuilder::new().create::<ipc::Service>().map_err(e)?;
        let event = |s: &str| {
            node.service_builder(&svc(&format!("{base}/{s}"))?)
                .event()
                .open_or_create()
                .map_err(e)
        };
        Ok(PingPong {
            ping: node
                .service_builder(&svc(&format!("{base}/ping"))?)
                .publish_subscribe::<[u64]>()
                .user_header::<StateHeader>()
                .open_or_create()
                .map_err(e)?,
            pong: node
                .service_builder(&svc(&format!("{base}/pong"))?)
                .publish_subscribe::<[u64]>()
                .user_header::<InputHeader>()
                .open_or_create()
                .map_err(e)?,
            ping_ev: event("ping-ev")?,
            pong_ev: event("pong-ev")?,
            _node: node,
        })
    }
}

/// Waits for the next message the way `mode` says (spinning is the
/// caller's loop).
pub(super) fn idle(mode: WaitMode, listen: &iceoryx2::port::listener::Listener<ipc::Service>) {
    if mode == WaitMode::Block {
        let _ = listen.timed_wait(|_| {}, Duration::from_millis(100));
    } else {
        std::hint::spin_loop();
    }
}

/// The echo side of the raw ping-pong.
pub(super) fn ponger(base: &str, mode: WaitMode) -> Result<(), BoxError> {
    let p = PingPong::open(base)?;
    let sub = p.ping.subscriber_builder().create().map_err(e)?;
    let publ = p
        .pong
        .publisher_builder()
        .initial_max_slice_len(1)
        .create()
        .map_err(e)?;
    let listen = p.ping_ev.listener_builder().create().map_err(e)?;
    let notify = p.pong_ev.notifier_builder().create().map_err(e)?;
    let mut reply = InputFrame::default();
    let mut got = StateFrame::default();
    loop {
        if let Some(s) = sub.receive().map_err(e)? {
            // Read as a controller reads a frame.
            got.read(s.user_header(), s.payload()).map_err(e)?;
            if got.step == u64::MAX {
                return Ok(());
            }
            reply.step = got.step;
            send_words(&publ, reply.header(), reply.words(), |w| reply.encode(w)).map_err(e)?;
            notify.notify().map_err(e)?;
            continue;
        }
        idle(mode, &listen);
    }
}

/// Median round trip (us) of `n` raw ping-pongs.
pub(super) fn raw_pingpong(mode: WaitMode, n: usize) -> Result<f64, BoxError> {
    let base = format!("cosim-bench-{}-{}", std::process::id(), mode.as_str());
    let p = PingPong::open(&base)?;
    // The reference scene's frame as the server publishes it.
    let engine = Engine::new(Model::from_scene(&cosim_shared::scenes::reference()?));
    let capacity = crate::serve::frame::contact_capacity(engine.model());
    let mut frame = StateFrame::default();
    crate::serve::frame::fill(&mut frame, &engine, None, capacity);
    let out = p
        .ping
        .publisher_builder()
        .initial_max_slice_len(crate::serve::frame::max_words(engine.model()))
        .create()
        .map_err(e)?;
    let inp = p.pong.subscriber_builder().create().map_err(e)?;
    let send = |frame: &StateFrame| {
        send_words(&out, frame.header(), frame.words(), |w| frame.encode(w)).map_err(e)
    };
    let notify = p.ping_ev.notifier_builder().create().map_err(e)?;
    let listen = p.pong_ev.listener_builder().create().map_err(e)?;
    let _peer = peer(&["pong", "--name", &base, "--wait", mode.as_str()])?;
    let mut times = Vec::with_capacity(n);
    // Until the ponger is subscribed, pings are lost: resend until a pong.
    let start = Instant::now();
    'warm: loop {
        frame.step = 0;
        send(&frame)?;
        notify.notify().map_err(e)?;
        let t = Instant::now();
        while t.elapsed() < Duration::from_millis(20) {
            if inp.receive().map_err(e)?.is_some() {
                break 'warm;
            }
        }
        if start.elapsed() > Duration::from_secs(20) {
            return Err("the ping-pong peer did not answer".into());
        }
    }
    for k in 1..=n as u64 {
        frame.step = k;
        let t0 = Instant::now();
        send(&frame)?;
        notify.notify().map_err(e)?;
        loop {
            if let Some(s) = inp.receive().map_err(e)? {
                if s.user_header().step == k {
                    break;
                }
                continue;
            }
            idle(mode, &listen);
        }
        times.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    frame.step = u64::MAX;
    send(&frame)?;
    Ok(median(&mut times))
}

pub(super) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Lockstep over TCP loopback: the server sends the state frame's bytes,
/// the controller answers with an input frame's bytes, per step.
/// Returns steps per second, the median round trip, the overhead per step
/// and the median wall time of a step (us).
pub(super) fn tcp_lockstep(steps: u64) -> Result<(f64, f64, f64, f64), BoxError> {
    let listener = std::net::TcpListener::bind("127.0.0.1:0")?;
    let port = listener.local_addr()?.port().to_string();
    let _peer = peer(&["tcp", "--name", &port, "--wait", "block"])?;
    let (mut sock, _) = listener.accept()?;
    sock.set_nodelay(true)?;
    let mut engine = Engine::new(Model::from_scene(&cosim_shared::scenes::reference()?));
    let capacity = crate::serve::frame::contact_capacity(engine.model());
    let mut frame = StateFrame::default();
    let mut bytes = Vec::new();
    let mut input = vec![0u8; input_bytes()];
    let mut times = Vec::with_capacity(steps as usize);
    let mut compute = 0.0;
    let mut step_walls = Vec::with_capacity(steps as usize);
    let start = Instant::now();
    for _ in 0..steps {
        let top = Instant::now();
        crate::serve::frame::fill(&mut frame, &engine, None, capacity);
        let t0 = Instant::now();
        sock.write_all(state_bytes(&frame, &mut bytes))?;
        sock.read_exact(&mut input)?;
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        let t1 = Instant::now();
        engine.step();
        compute += t1.elapsed().as_secs_f64();
        step_walls.push(top.elapsed().as_secs_f64() * 1e6);
    }
    let wall = start.elapsed().as_secs_f64();
    let over = (wall - compute) / steps as f64 * 1e6;
    Ok((
        steps as f64 / wall,
        median(&mut times),
        over,
        median(&mut step_walls),
    ))
}

/// A state frame as a socket carries it: its length, a header's worth
/// of bytes (the step first) and the payload words, as many bytes as the
/// shared-memory message has.
pub(super) fn state_bytes<'a>(f: &StateFrame, out: &'a mut Vec<u8>) -> &'a [u8] {
    struct Bytes<'b>(&'b mut Vec<u8>);
    impl WordSink for Bytes<'_> {
        fn put(&mut self, word: u64) {
            self.0.extend_from_slice(&word.to_le_bytes());
        }
    }
    out.clear();
    let len = std::mem::size_of::<StateHeader>() + 8 * f.words();
    out.extend_from_slice(&(len as u64).to_le_bytes());
    out.extend_from_slice(&f.step.to_le_bytes());
    out.resize(8 + std::mem::size_of::<StateHeader>(), 0);
    f.encode(&mut Bytes(out));
    out
}

/// An empty input as a socket carries it: a header's worth of bytes.
pub(super) fn input_bytes() -> usize {
    std::mem::size_of::<InputHeader>()
}
