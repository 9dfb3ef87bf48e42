//! An MCAP recording for Foxglove, written message by message: a channel
//! per topic, made with its schema on the topic's first message. Both
//! `cosim-server run --mcap` (from a run's files) and `cosim record
//! --mcap` (from the frames it reads) write through it.

use crate::draw;
use crate::schema::Schema;
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt;
use std::io::BufWriter;
use std::path::Path;

/// Why a recording could not be written.
#[derive(Debug)]
pub struct RecordError(pub String);

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write the recording: {}", self.0)
    }
}

impl std::error::Error for RecordError {}

fn fail(e: impl fmt::Display) -> RecordError {
    RecordError(e.to_string())
}

/// What a recording holds: messages per topic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Written {
    pub messages: BTreeMap<String, u64>,
    /// What the recording leaves out, each said (a visual mesh that could
    /// not be read).
    pub not_drawn: Vec<String>,
}

/// An open recording.
pub struct Recording {
    w: mcap::Writer<BufWriter<std::fs::File>>,
    written: Written,
    topics: BTreeMap<String, u16>,
    schemas: BTreeMap<&'static str, u16>,
}

impl Recording {
    /// Creates the file (uncompressed: the `mcap` crate without its zstd
    /// and lz4 back ends, C code and build time for little gain here).
    pub fn create(path: &Path) -> Result<Recording, RecordError> {
        let file = std::fs::File::create(path)
            .map_err(|e| RecordError(format!("{}: {e}", path.display())))?;
        let w = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .create(BufWriter::new(file))
            .map_err(fail)?;
        Ok(Recording {
            w,
            written: Written::default(),
            topics: BTreeMap::new(),
            schemas: BTreeMap::new(),
        })
    }

    fn channel(
        &mut self,
        topic: &str,
        schema: impl FnOnce() -> Schema,
    ) -> Result<u16, RecordError> {
        if let Some(&id) = self.topics.get(topic) {
            return Ok(id);
        }
        let schema = schema();
        let schema_id = match self.schemas.get(schema.name) {
            Some(&id) => id,
            None => {
                let id = self
                    .w
                    .add_schema(schema.name, "jsonschema", schema.text.as_bytes())
                    .map_err(fail)?;
                self.schemas.insert(schema.name, id);
                id
            }
        };
        let id = self
            .w
            .add_channel(schema_id, topic, "json", &BTreeMap::new())
            .map_err(fail)?;
        self.topics.insert(topic.to_string(), id);
        Ok(id)
    }

    /// Writes `msg` on `topic` at simulated time `t` (s); the topic's
    /// first message makes its channel with `schema`.
    pub fn put(
        &mut self,
        topic: &str,
        schema: impl FnOnce() -> Schema,
        t: f64,
        msg: &Value,
    ) -> Result<(), RecordError> {
        let channel = self.channel(topic, schema)?;
        let count = self.written.messages.entry(topic.to_string()).or_default();
        let ns = draw::nanos(t);
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: *count as u32,
            log_time: ns,
            publish_time: ns,
        };
        *count += 1;
        self.w
            .write_to_known_channel(&header, msg.to_string().as_bytes())
            .map_err(fail)
    }

    /// What has been written so far.
    pub fn written(&self) -> &Written {
        &self.written
    }

    /// Says that `what` is not in the recording.
    pub fn not_drawn(&mut self, what: impl IntoIterator<Item = String>) {
        self.written.not_drawn.extend(what);
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<Written, RecordError> {
        self.w.finish().map_err(fail)?;
        Ok(self.written)
    }
}
