//! `cosim view`: a running server's state, live in Foxglove.
//!
//! A monitor ([`Monitor::polling`]: it reads the newest frame at the
//! view's rate and adds nothing to the server's step, not even an event)
//! that serves the Foxglove WebSocket protocol ([`cosim_foxglove::live`]).
//! In Foxglove: Open connection, Foxglove WebSocket, `ws://HOST:PORT`.
//!
//! Channels, each at most once per newest frame and at most `rate` times
//! a second (a state frame comes every step; a display needs far fewer):
//! - `/scene` (`foxglove.SceneUpdate`): spheres, planes, joint links and
//!   the last step's normal contact forces as arrows, drawn as the
//!   recordings draw them (`cosim-server run --mcap`);
//! - `/tf` (`foxglove.FrameTransforms`): `world` to each body;
//! - `/bodies/NAME` (`cosim.BodyState`);
//! - `/joints/NAME` (`cosim.JointCoordinate`): a hinge's angle or a
//!   slider's offset and its rate, from the frame (protocol 3), as the
//!   recordings and joints.csv have them;
//! - `/solver` (`cosim.StepReport`): step, LCP size, residual, contacts,
//!   controllers, solver status;
//!
//! and the simulated time (the protocol's time message). Messages are
//! built only for channels someone subscribes to.

use crate::{Connection, Monitor, StateFrame, STATUS_SHUTDOWN};
use cosim_foxglove::draw::{self, Arrow, Drawing, Pose};
use cosim_foxglove::live::{Event, Live};
use cosim_foxglove::{schema, Channel};
use cosim_shared::wire::BodyFrame;
use cosim_shared::JointKind;
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

/// How `cosim view` runs.
#[derive(Debug, Clone)]
pub struct ViewOptions {
    /// Address to listen on, `HOST:PORT` (port 0: any free port).
    pub listen: String,
    /// Most frames per second sent to Foxglove.
    pub rate: f64,
    /// Stop after this many seconds of wall time.
    pub seconds: Option<f64>,
}

/// What a view did, when it ends.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewStats {
    /// Server frames drawn.
    pub frames: u64,
    /// Messages queued for clients, and dropped for slow ones.
    pub sent: u64,
    pub dropped: u64,
}

const SCENE: u32 = 1;
const TF: u32 = 2;
const SOLVER: u32 = 3;
/// `/shapes` and `/visuals` (those the scene has), from channel `ONCE`
/// on: sent to each new subscriber.
const ONCE: u32 = 4;
/// `/bodies/NAME` of body `i` is channel `BODIES + i`; `/joints/NAME` of
/// joint `j` (hinges and sliders only) is `BODIES + bodies + j`.
const BODIES: u32 = 16;

/// The channel of joint `j`'s coordinate in a scene of `bodies` bodies.
fn joint_channel(bodies: usize, j: usize) -> u32 {
    BODIES + (bodies + j) as u32
}

/// Serves server `name`'s state to Foxglove until the server stops, the
/// time is up or the process is interrupted. `listening` is called once
/// with the address bound (for a caller that chose port 0).
pub fn view(
    name: &str,
    opts: &ViewOptions,
    listening: impl FnOnce(SocketAddr),
) -> Result<ViewStats, Box<dyn std::error::Error>> {
    let conn = Connection::connect(name)?;
    let scene = cosim_shared::Scene::parse(&conn.scene_toml()?, "<server scene>")?;
    let drawing = Drawing::new(&scene);
    let mut points = ContactPoints::new(&scene);
    let mut channels = vec![
        Channel {
            id: SCENE,
            topic: "/scene".into(),
            schema: schema::scene_update(),
        },
        Channel {
            id: TF,
            topic: "/tf".into(),
            schema: schema::frame_transforms(),
        },
        Channel {
            id: SOLVER,
            topic: "/solver".into(),
            schema: schema::step_report(&SOLVER_FIELDS),
        },
    ];
    for (i, b) in drawing.bodies().iter().enumerate() {
        channels.push(Channel {
            id: BODIES + i as u32,
            topic: format!("/bodies/{b}"),
            schema: schema::body_state(),
        });
    }
    let bodies = drawing.bodies().len();
    for (j, joint) in scene.joints.iter().enumerate() {
        if matches!(joint.kind, JointKind::Revolute | JointKind::Prismatic) {
            channels.push(Channel {
                id: joint_channel(bodies, j),
                topic: format!("/joints/{}", joint.name),
                schema: schema::joint_coordinate(),
            });
        }
    }
    let (once, not_drawn) = cosim_foxglove::visuals::sent_once(&scene, &drawing);
    for what in &not_drawn {
        eprintln!("cosim view: warning: not drawn: {what}");
    }
    // Channel id and text of each message sent to a new subscriber.
    let once: Vec<(u32, String)> = once
        .iter()
        .enumerate()
        .map(|(k, (topic, msg))| {
            channels.push(Channel {
                id: ONCE + k as u32,
                topic: topic.to_string(),
                schema: schema::scene_update(),
            });
            (ONCE + k as u32, msg.to_string())
        })
        .collect();
    let mut live = Live::bind(opts.listen.as_str(), &format!("cosim {name}"), channels)?;
    live.allow_message(once.iter().map(|(_, m)| m.len()).sum());
    let monitor = Monitor::polling(name)?;
    listening(live.local_addr()?);
    let period = Duration::from_secs_f64(1.0 / opts.rate.max(0.1));
    let start = Instant::now();
    let mut last_sequence = 0;
    let mut last_alive_check = Instant::now();
    let mut stats = ViewStats::default();
    loop {
        for e in live.poll() {
            match e {
                Event::Connected(p) => eprintln!("cosim view: Foxglove client {p} connected"),
                Event::Disconnected(p) => eprintln!("cosim view: client {p} left"),
                Event::Refused(p, why) => eprintln!("cosim view: refused {p}: {why}"),
                Event::BadRequest(p, why) => eprintln!("cosim view: client {p}: {why}"),
                Event::Subscribed(_, channel) => {
                    for (id, m) in &once {
                        if *id == channel {
                            live.publish(*id, 0, m.as_bytes());
                        }
                    }
                }
            }
        }
        if let Some(f) = monitor.latest()? {
            if f.sequence != last_sequence {
                last_sequence = f.sequence;
                stats.frames += 1;
                send(&mut live, &drawing, &mut points, &f);
                if f.status & STATUS_SHUTDOWN != 0 {
                    break;
                }
            }
        }
        if opts
            .seconds
            .is_some_and(|s| start.elapsed().as_secs_f64() > s)
        {
            break;
        }
        if last_alive_check.elapsed() > Duration::from_secs(1) {
            last_alive_check = Instant::now();
            if !conn.server_alive() {
                eprintln!("cosim view: the server '{name}' is gone");
                break;
            }
        }
        match monitor.node().wait(period) {
            Ok(()) => {}
            // SIGINT or SIGTERM: the view ends like the server's monitors.
            Err(_) => break,
        }
    }
    stats.sent = live.sent();
    stats.dropped = live.dropped();
    Ok(stats)
}

/// The numeric fields of `/solver`.
pub(crate) const SOLVER_FIELDS: [&str; 7] = [
    "step",
    "sim_time",
    "lcp_size",
    "residual",
    "contacts",
    "controllers",
    "solver_status",
];

/// One frame to the channels someone subscribes to.
fn send(live: &mut Live, drawing: &Drawing, points: &mut ContactPoints, f: &StateFrame) {
    let t = f.sim_time;
    let ns = draw::nanos(t);
    live.time(ns);
    let poses = poses(f);
    if live.subscribed(SCENE) {
        let msg = scene_message(drawing, points, f, &poses);
        live.publish(SCENE, ns, msg.to_string().as_bytes());
    }
    if live.subscribed(TF) {
        let msg = drawing.frame_transforms(t, &poses);
        live.publish(TF, ns, msg.to_string().as_bytes());
    }
    if live.subscribed(SOLVER) {
        live.publish(SOLVER, ns, solver_message(f).to_string().as_bytes());
    }
    for (i, b) in f.bodies().iter().enumerate() {
        let channel = BODIES + i as u32;
        if live.subscribed(channel) {
            let msg = draw::body_state(&body_row(b));
            live.publish(channel, ns, msg.to_string().as_bytes());
        }
    }
    // A spherical or fixed joint has no channel, so never a subscriber.
    let bodies = f.bodies().len();
    for (j, [x, v]) in f.joint_coordinates.iter().enumerate() {
        let channel = joint_channel(bodies, j);
        if live.subscribed(channel) {
            let msg = draw::joint_coordinate(*x, *v);
            live.publish(channel, ns, msg.to_string().as_bytes());
        }
    }
}

/// The frame's body poses.
pub(crate) fn poses(f: &StateFrame) -> Vec<Pose> {
    f.bodies()
        .iter()
        .map(|b| Pose::new(b.position, b.orientation))
        .collect()
}

/// A body of a frame as the 13 numbers of a states.csv row.
pub(crate) fn body_row(b: &BodyFrame) -> [f64; 13] {
    let mut row = [0.0; 13];
    row[0..3].copy_from_slice(&b.position);
    row[3..7].copy_from_slice(&b.orientation);
    row[7..10].copy_from_slice(&b.linear_velocity);
    row[10..13].copy_from_slice(&b.angular_velocity);
    row
}

/// `/solver`: what the frame's header says of the last step.
pub(crate) fn solver_message(f: &StateFrame) -> Value {
    json!({
        "step": f.step, "sim_time": f.sim_time, "lcp_size": f.lcp_size,
        "residual": f.residual, "contacts": f.contact_count,
        "controllers": f.controller_count, "solver_status": f.solver_status
    })
}

/// Where a frame's contacts touch: the engine's collision recomputed from
/// the frame's poses (a frame carries each contact's id and impulses, not
/// its point).
pub(crate) struct ContactPoints {
    model: cosim_engine::Model,
    state: cosim_engine::State,
}

impl ContactPoints {
    pub(crate) fn new(scene: &cosim_shared::Scene) -> ContactPoints {
        let model = cosim_engine::Model::from_scene(scene);
        let state = cosim_engine::State::initial(&model);
        ContactPoints { model, state }
    }

    /// Takes the frame's poses; the points below are theirs.
    fn pose(&mut self, poses: &[Pose]) {
        for (b, p) in self.state.bodies.iter_mut().zip(poses) {
            b.x = p.position;
            b.q = p.orientation;
        }
    }

    fn point(&self, id: usize) -> Option<Vector3<f64>> {
        cosim_engine::collision::contact_point(&self.model, &self.state, id)
    }
}

/// `/scene`: the frame drawn, with the last step's normal contact forces
/// (impulse over h) as arrows at their points.
pub(crate) fn scene_message(
    drawing: &Drawing,
    points: &mut ContactPoints,
    f: &StateFrame,
    poses: &[Pose],
) -> Value {
    let h = if f.dt > 0.0 { f.dt } else { 1.0 };
    points.pose(poses);
    let arrows: Vec<Arrow> = f
        .contacts()
        .iter()
        .filter_map(|c| {
            Some(Arrow {
                at: points.point(c.id as usize)?,
                force: Vector3::from(c.normal) / h,
            })
        })
        .collect();
    drawing.scene_update(f.sim_time, poses, &arrows)
}
