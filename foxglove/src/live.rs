//! A Foxglove WebSocket server (protocol `foxglove.websocket.v1`, the
//! subset a data source needs): it advertises channels, takes
//! `subscribe` and `unsubscribe`, and sends message data and the time.
//!
//! One thread, no runtime: [`Live::poll`] accepts connections and reads
//! the clients' requests without blocking, [`Live::publish`] queues a
//! message for each subscriber and writes what the socket takes now. A
//! client that reads too slowly loses messages (counted in
//! [`Live::dropped`]) instead of slowing the caller: the view is a
//! monitor, and the simulation never waits for it.
//!
//! Messages (the protocol's specification, docs/spec.md of
//! foxglove/ws-protocol): JSON text `serverInfo` and `advertise` on
//! connection, `status` for a request that cannot be served; binary
//! message data `[0x01][subscription id: u32 LE][time: u64 LE ns][payload]`
//! and time `[0x02][time: u64 LE ns]` (capability `time`: Foxglove then
//! follows the simulated time).

use crate::schema::Schema;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io;
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::time::Duration;
use tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tungstenite::protocol::WebSocketConfig;
use tungstenite::{Message, WebSocket};

/// The subprotocol of the Foxglove WebSocket protocol, version 1.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Binary opcodes, server to client.
pub const OP_MESSAGE_DATA: u8 = 1;
pub const OP_TIME: u8 = 2;
/// Bytes a slow client may have queued before its messages are dropped.
const MAX_QUEUED: usize = 8 << 20;
/// Time a new connection has to finish its WebSocket handshake.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(2);

/// A channel as advertised: id, topic, JSON encoding and its schema.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    pub id: u32,
    pub topic: String,
    pub schema: Schema,
}

struct Client {
    ws: WebSocket<TcpStream>,
    peer: SocketAddr,
    /// Subscription id -> channel id.
    subscriptions: BTreeMap<u32, u32>,
}

/// What happened in one [`Live::poll`], for the caller's log.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Connected(SocketAddr),
    /// A connection that is not a Foxglove client (no handshake, or not
    /// the subprotocol), with why.
    Refused(SocketAddr, String),
    Disconnected(SocketAddr),
    /// A request that could not be served; the client was told the same
    /// in a `status` message.
    BadRequest(SocketAddr, String),
    /// A client subscribed to a channel (its id): what is sent once
    /// (`/visuals`) goes now.
    Subscribed(SocketAddr, u32),
}

/// The server: a listener, the channels, the connected clients.
pub struct Live {
    listener: TcpListener,
    info: String,
    advertise: String,
    channels: BTreeMap<u32, Channel>,
    clients: Vec<Client>,
    dropped: u64,
    sent: u64,
    /// Bytes a client may have queued (at least [`MAX_QUEUED`]).
    max_queued: usize,
}

impl Live {
    /// Listens on `addr` (port 0: any free port, see [`Live::local_addr`])
    /// as server `name`, advertising `channels` to every client.
    pub fn bind(addr: impl ToSocketAddrs, name: &str, channels: Vec<Channel>) -> io::Result<Live> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let session = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis());
        let info = json!({
            "op": "serverInfo", "name": name, "capabilities": ["time"],
            "supportedEncodings": [], "metadata": {}, "sessionId": session.to_string()
        })
        .to_string();
        let list: Vec<Value> = channels
            .iter()
            .map(|c| {
                json!({ "id": c.id, "topic": c.topic, "encoding": "json",
                        "schemaName": c.schema.name, "schema": c.schema.text,
                        "schemaEncoding": "jsonschema" })
            })
            .collect();
        let advertise = json!({ "op": "advertise", "channels": list }).to_string();
        Ok(Live {
            listener,
            info,
            advertise,
            channels: channels.into_iter().map(|c| (c.id, c)).collect(),
            clients: Vec::new(),
            dropped: 0,
            sent: 0,
            max_queued: MAX_QUEUED,
        })
    }

    /// Lets clients that connect from now on queue a message of `bytes`
    /// beside the usual [`MAX_QUEUED`] (the visual meshes, sent once).
    pub fn allow_message(&mut self, bytes: usize) {
        self.max_queued = self.max_queued.max(MAX_QUEUED + bytes + 64);
    }

    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.clients.len()
    }

    /// Messages not sent because a client had [`MAX_QUEUED`] bytes queued.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Messages queued for clients.
    pub fn sent(&self) -> u64 {
        self.sent
    }

    /// Whether any client subscribes to `channel` (the caller skips
    /// building messages nobody reads).
    pub fn subscribed(&self, channel: u32) -> bool {
        self.clients
            .iter()
            .any(|c| c.subscriptions.values().any(|&ch| ch == channel))
    }

    /// Accepts new connections, reads the clients' requests and writes
    /// what they have queued; returns what happened. Never blocks, but
    /// for a new connection's handshake (at most [`HANDSHAKE_TIMEOUT`]).
    pub fn poll(&mut self) -> Vec<Event> {
        let mut events = Vec::new();
        loop {
            match self.listener.accept() {
                Ok((stream, peer)) => match self.handshake(stream) {
                    Ok(client) => {
                        events.push(Event::Connected(peer));
                        self.clients.push(client);
                    }
                    Err(why) => events.push(Event::Refused(peer, why)),
                },
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                // A connection reset before it was accepted: nothing to do.
                Err(_) => break,
            }
        }
        let channels = &self.channels;
        self.clients.retain_mut(|c| {
            let alive = read_requests(c, channels, &mut events);
            if !alive {
                events.push(Event::Disconnected(c.peer));
            }
            alive
        });
        events
    }

    /// The WebSocket handshake (blocking, with a timeout), then the
    /// protocol's greeting: server info and the channels.
    // The refusal's type is tungstenite's (its handshake callback's).
    #[allow(clippy::result_large_err)]
    fn handshake(&self, stream: TcpStream) -> Result<Client, String> {
        let peer = stream.peer_addr().map_err(|e| e.to_string())?;
        stream
            .set_nonblocking(false)
            .and_then(|()| stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT)))
            .and_then(|()| stream.set_write_timeout(Some(HANDSHAKE_TIMEOUT)))
            .map_err(|e| e.to_string())?;
        let choose = |req: &Request, mut resp: Response| -> Result<Response, ErrorResponse> {
            let offered = req
                .headers()
                .get_all("Sec-WebSocket-Protocol")
                .iter()
                .filter_map(|v| v.to_str().ok())
                .flat_map(|v| v.split(','))
                .any(|p| p.trim() == SUBPROTOCOL);
            if !offered {
                let mut refusal = ErrorResponse::new(Some(format!(
                    "this is a Foxglove WebSocket server: ask for the subprotocol {SUBPROTOCOL}"
                )));
                *refusal.status_mut() = tungstenite::http::StatusCode::BAD_REQUEST;
                return Err(refusal);
            }
            resp.headers_mut().insert(
                "Sec-WebSocket-Protocol",
                tungstenite::http::HeaderValue::from_static(SUBPROTOCOL),
            );
            Ok(resp)
        };
        let config = WebSocketConfig::default().max_write_buffer_size(self.max_queued);
        let mut ws = tungstenite::accept_hdr_with_config(stream, choose, Some(config))
            .map_err(|e| e.to_string())?;
        for text in [&self.info, &self.advertise] {
            ws.send(Message::text(text.as_str()))
                .map_err(|e| e.to_string())?;
        }
        ws.get_mut()
            .set_nonblocking(true)
            .map_err(|e| e.to_string())?;
        Ok(Client {
            ws,
            peer,
            subscriptions: BTreeMap::new(),
        })
    }

    /// Sends `payload` on `channel`, stamped `t_ns`, to its subscribers.
    pub fn publish(&mut self, channel: u32, t_ns: u64, payload: &[u8]) {
        let mut dropped = 0;
        let mut sent = 0;
        self.clients.retain_mut(|c| {
            let subs: Vec<u32> = c
                .subscriptions
                .iter()
                .filter(|(_, &ch)| ch == channel)
                .map(|(&s, _)| s)
                .collect();
            for sub in subs {
                let mut data = Vec::with_capacity(13 + payload.len());
                data.push(OP_MESSAGE_DATA);
                data.extend_from_slice(&sub.to_le_bytes());
                data.extend_from_slice(&t_ns.to_le_bytes());
                data.extend_from_slice(payload);
                match queue(c, Message::binary(data)) {
                    Queued::Yes => sent += 1,
                    Queued::Full => dropped += 1,
                    Queued::Gone => return false,
                }
            }
            flush(c)
        });
        self.dropped += dropped;
        self.sent += sent;
    }

    /// Tells every client the current (simulated) time.
    pub fn time(&mut self, t_ns: u64) {
        let mut data = Vec::with_capacity(9);
        data.push(OP_TIME);
        data.extend_from_slice(&t_ns.to_le_bytes());
        self.clients.retain_mut(|c| {
            !matches!(queue(c, Message::binary(data.clone())), Queued::Gone) && flush(c)
        });
    }
}

enum Queued {
    Yes,
    /// The client's queue is full: the message is dropped.
    Full,
    /// The connection failed.
    Gone,
}

fn queue(c: &mut Client, m: Message) -> Queued {
    match c.ws.write(m) {
        Ok(()) => Queued::Yes,
        Err(tungstenite::Error::WriteBufferFull(_)) => Queued::Full,
        Err(tungstenite::Error::Io(e)) if e.kind() == io::ErrorKind::WouldBlock => Queued::Yes,
        Err(_) => Queued::Gone,
    }
}

/// Writes what the socket takes now; false when the connection failed.
fn flush(c: &mut Client) -> bool {
    match c.ws.flush() {
        Ok(()) => true,
        Err(tungstenite::Error::Io(e)) if e.kind() == io::ErrorKind::WouldBlock => true,
        Err(_) => false,
    }
}

/// Reads a client's pending requests; false when it left.
fn read_requests(
    c: &mut Client,
    channels: &BTreeMap<u32, Channel>,
    events: &mut Vec<Event>,
) -> bool {
    loop {
        match c.ws.read() {
            Ok(Message::Text(text)) => {
                let before: Vec<u32> = c.subscriptions.values().copied().collect();
                let result = request(c, channels, text.as_str());
                for &ch in c.subscriptions.values() {
                    if !before.contains(&ch) {
                        events.push(Event::Subscribed(c.peer, ch));
                    }
                }
                if let Err(why) = result {
                    events.push(Event::BadRequest(c.peer, why.clone()));
                    let status = json!({ "op": "status", "level": 2, "message": why }).to_string();
                    if matches!(queue(c, Message::text(status)), Queued::Gone) {
                        return false;
                    }
                }
            }
            Ok(Message::Close(_)) => return false,
            // Pings are answered by tungstenite; the protocol has no
            // binary request this server takes (client publishing is not
            // among its capabilities).
            Ok(_) => {}
            Err(tungstenite::Error::Io(e)) if e.kind() == io::ErrorKind::WouldBlock => break,
            Err(_) => return false,
        }
    }
    flush(c)
}

/// One JSON request: subscribe or unsubscribe. An error names the
/// operation and field at fault.
fn request(c: &mut Client, channels: &BTreeMap<u32, Channel>, text: &str) -> Result<(), String> {
    let v: Value =
        serde_json::from_str(text).map_err(|e| format!("a request that is not JSON: {e}"))?;
    let op = v["op"]
        .as_str()
        .ok_or("a request without a string field \"op\"")?;
    let id = |x: &Value, field: &str| -> Result<u32, String> {
        x[field]
            .as_u64()
            .and_then(|n| u32::try_from(n).ok())
            .ok_or_else(|| format!("{op}: field \"{field}\" is not a 32-bit unsigned integer"))
    };
    match op {
        "subscribe" => {
            let subs = v["subscriptions"]
                .as_array()
                .ok_or("subscribe: field \"subscriptions\" is not an array")?;
            for s in subs {
                let (sub, ch) = (id(s, "id")?, id(s, "channelId")?);
                if !channels.contains_key(&ch) {
                    return Err(format!("subscribe: no channel with channelId {ch}"));
                }
                if c.subscriptions.contains_key(&sub) {
                    return Err(format!("subscribe: subscription id {sub} is in use"));
                }
                c.subscriptions.insert(sub, ch);
            }
            Ok(())
        }
        "unsubscribe" => {
            let ids = v["subscriptionIds"]
                .as_array()
                .ok_or("unsubscribe: field \"subscriptionIds\" is not an array")?;
            for s in ids {
                let sub = s
                    .as_u64()
                    .and_then(|n| u32::try_from(n).ok())
                    .ok_or("unsubscribe: a subscription id is not a 32-bit unsigned integer")?;
                c.subscriptions.remove(&sub);
            }
            Ok(())
        }
        other => Err(format!(
            "operation \"{other}\" is not served here (subscribe, unsubscribe)"
        )),
    }
}
