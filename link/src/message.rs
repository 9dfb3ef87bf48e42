//! What the two halves of a link say to each other over Zenoh: the
//! protocol's own structs and words (docs/protocol.md), framed with the
//! local client they belong to. Little-endian, as the protocol is.

use cosim_shared::wire::{ControlRequest, ControlResponse, InputHeader, StateHeader};

/// A protocol struct sent as its bytes: `#[repr(C)]`, every field an
/// integer, a float or an array of them, no implicit padding (the
/// protocol's rule, docs/protocol.md), so every byte pattern of its size
/// is a value.
pub trait Plain: Copy {}
impl Plain for StateHeader {}
impl Plain for InputHeader {}
impl Plain for ControlRequest {}
impl Plain for ControlResponse {}

/// The bytes of `v`, appended to `out`.
pub fn put_struct<T: Plain>(v: &T, out: &mut Vec<u8>) {
    // SAFETY: `T: Plain` is `repr(C)` without padding, so its
    // `size_of::<T>()` bytes are all initialised; the slice borrows `v`.
    let bytes = unsafe {
        core::slice::from_raw_parts((v as *const T).cast::<u8>(), core::mem::size_of::<T>())
    };
    out.extend_from_slice(bytes);
}

/// A `T` read from the front of `bytes`, and the rest; `None` when there
/// are too few.
pub fn take_struct<T: Plain>(bytes: &[u8]) -> Option<(T, &[u8])> {
    let n = core::mem::size_of::<T>();
    if bytes.len() < n {
        return None;
    }
    // SAFETY: `bytes` holds at least `size_of::<T>()` bytes (checked
    // above), every byte pattern is a `T` (`Plain`), and the read is
    // unaligned-safe.
    let v = unsafe { core::ptr::read_unaligned(bytes.as_ptr().cast::<T>()) };
    Some((v, &bytes[n..]))
}

/// Words appended as little-endian bytes.
pub fn put_words(words: &[u64], out: &mut Vec<u8>) {
    out.reserve(8 * words.len());
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

/// The words of `bytes` (a whole number of them), into `out`.
pub fn take_words(bytes: &[u8], out: &mut Vec<u64>) -> Option<()> {
    if !bytes.len().is_multiple_of(8) {
        return None;
    }
    out.clear();
    out.extend(bytes.chunks_exact(8).map(|c| {
        let mut w = [0u8; 8];
        w.copy_from_slice(c);
        u64::from_le_bytes(w)
    }));
    Some(())
}

/// A message between the halves about one local client of the importing
/// side: `client` is that client's iceoryx2 node id on its host, `seq`
/// numbers its control requests.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// Importer to exporter: an input (its header and words).
    Input { client: u128, bytes: Vec<u8> },
    /// Importer to exporter: a control request.
    Request {
        client: u128,
        seq: u64,
        request: ControlRequest,
    },
    /// Importer to exporter: the client's process is gone (exited, or its
    /// node found dead twice).
    Gone { client: u128 },
    /// Exporter to importer: one response to request `seq`.
    Response {
        client: u128,
        seq: u64,
        response: ControlResponse,
    },
    /// Exporter to importer: the server let request `seq` go (every
    /// response sent), or cannot be reached.
    End { client: u128, seq: u64 },
}

const INPUT: u8 = 1;
const REQUEST: u8 = 2;
const GONE: u8 = 3;
const RESPONSE: u8 = 4;
const END: u8 = 5;
const FRAME: usize = 32;

impl Message {
    pub fn client(&self) -> u128 {
        match self {
            Message::Input { client, .. }
            | Message::Request { client, .. }
            | Message::Gone { client }
            | Message::Response { client, .. }
            | Message::End { client, .. } => *client,
        }
    }

    /// Tag, seven zero bytes, the client (16 bytes), the sequence (8),
    /// the body.
    pub fn encode(&self) -> Vec<u8> {
        let (tag, seq) = match self {
            Message::Input { .. } => (INPUT, 0),
            Message::Request { seq, .. } => (REQUEST, *seq),
            Message::Gone { .. } => (GONE, 0),
            Message::Response { seq, .. } => (RESPONSE, *seq),
            Message::End { seq, .. } => (END, *seq),
        };
        let mut out = Vec::with_capacity(FRAME + 256);
        out.push(tag);
        out.extend_from_slice(&[0; 7]);
        out.extend_from_slice(&self.client().to_le_bytes());
        out.extend_from_slice(&seq.to_le_bytes());
        match self {
            Message::Input { bytes, .. } => out.extend_from_slice(bytes),
            Message::Request { request, .. } => put_struct(request, &mut out),
            Message::Response { response, .. } => put_struct(response, &mut out),
            Message::Gone { .. } | Message::End { .. } => {}
        }
        out
    }

    /// The message of `bytes`; `None` when they are not one (the other
    /// half is another version of this program).
    pub fn decode(bytes: &[u8]) -> Option<Message> {
        if bytes.len() < FRAME {
            return None;
        }
        let client = u128::from_le_bytes(bytes[8..24].try_into().ok()?);
        let seq = u64::from_le_bytes(bytes[24..32].try_into().ok()?);
        let body = &bytes[FRAME..];
        let exact = |rest: &[u8]| rest.is_empty();
        Some(match bytes[0] {
            INPUT => Message::Input {
                client,
                bytes: body.to_vec(),
            },
            REQUEST => {
                let (request, rest) = take_struct::<ControlRequest>(body)?;
                exact(rest).then_some(())?;
                Message::Request {
                    client,
                    seq,
                    request,
                }
            }
            GONE => Message::Gone { client },
            RESPONSE => {
                let (response, rest) = take_struct::<ControlResponse>(body)?;
                exact(rest).then_some(())?;
                Message::Response {
                    client,
                    seq,
                    response,
                }
            }
            END => Message::End { client, seq },
            _ => return None,
        })
    }
}

/// A state frame's bytes: its header, then its words.
pub fn state_bytes(header: &StateHeader, words: &[u64]) -> Vec<u8> {
    let mut out = Vec::with_capacity(core::mem::size_of::<StateHeader>() + 8 * words.len());
    put_struct(header, &mut out);
    put_words(words, &mut out);
    out
}

/// An input's bytes: its header, then its words.
pub fn input_bytes(header: &InputHeader, words: &[u64]) -> Vec<u8> {
    let mut out = Vec::with_capacity(core::mem::size_of::<InputHeader>() + 8 * words.len());
    put_struct(header, &mut out);
    put_words(words, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_message_reads_back_as_sent() {
        let mut response = ControlResponse {
            status: 3,
            controller_id: 7,
            step: 42,
            ..Default::default()
        };
        response.set_message("controller 7 was joined by another process");
        let input = input_bytes(
            &InputHeader {
                version: 4,
                controller_id: 2,
                step: 9,
                torque_count: 1,
                ..Default::default()
            },
            &[1, 2, 3, u64::MAX],
        );
        let client = (0xfeed_u128 << 64) | 0xbeef;
        for m in [
            Message::Input {
                client,
                bytes: input,
            },
            Message::Request {
                client,
                seq: 5,
                request: ControlRequest {
                    version: 4,
                    command: 1,
                    role: 1,
                    pid: 1234,
                    ..Default::default()
                },
            },
            Message::Gone { client },
            Message::Response {
                client,
                seq: 5,
                response,
            },
            Message::End { client, seq: 6 },
        ] {
            assert_eq!(Message::decode(&m.encode()), Some(m));
        }
    }

    #[test]
    fn a_frame_keeps_its_header_and_words() {
        let header = StateHeader {
            version: 4,
            step: 17,
            sim_time: 0.017,
            body_count: 1,
            dt: 1e-3,
            ..Default::default()
        };
        let words: Vec<u64> = (0..13).map(|i| (i as f64 * 0.5).to_bits()).collect();
        let bytes = state_bytes(&header, &words);
        let (h, rest) = take_struct::<StateHeader>(&bytes).expect("a header");
        let mut back = Vec::new();
        take_words(rest, &mut back).expect("whole words");
        assert_eq!((h, back), (header, words));
    }

    #[test]
    fn what_is_not_a_message_is_refused() {
        assert_eq!(Message::decode(&[]), None);
        let mut bad = Message::End { client: 1, seq: 1 }.encode();
        bad[0] = 99;
        assert_eq!(Message::decode(&bad), None);
        let mut short = Message::Request {
            client: 1,
            seq: 1,
            request: ControlRequest::default(),
        }
        .encode();
        short.pop();
        assert_eq!(Message::decode(&short), None);
        assert_eq!(take_words(&[0; 7], &mut Vec::new()), None);
    }
}
