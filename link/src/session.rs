//! The Zenoh side of a link: where it listens or connects, and the key
//! expressions of server `NAME` (everything under `cosim/NAME/link/`).

use std::fmt;
use zenoh::Wait;

/// Why a link could not start or went on no longer.
#[derive(Debug)]
pub enum LinkError {
    /// Zenoh refused, with what was asked of it.
    Zenoh { what: String, detail: String },
    /// The local side (iceoryx2, the server's services).
    Local { what: String, detail: String },
    /// The other half did not answer in time.
    NoPeer { name: String, waited_s: f64 },
    /// A server name that cannot be a key expression.
    BadName(String),
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::Zenoh { what, detail } => write!(f, "zenoh: {what}: {detail}"),
            LinkError::Local { what, detail } => write!(f, "{what}: {detail}"),
            LinkError::NoPeer { name, waited_s } => write!(
                f,
                "no `cosim-link export {name}` answered within {waited_s:.1} s (is it running, and does --connect reach it?)"
            ),
            LinkError::BadName(n) => write!(
                f,
                "server name {n:?} cannot name Zenoh keys (no '*', '$', '#', '?' or empty '/' parts)"
            ),
        }
    }
}

impl std::error::Error for LinkError {}

pub fn zenoh_err(what: impl Into<String>) -> impl FnOnce(zenoh::Error) -> LinkError {
    let what = what.into();
    move |e| LinkError::Zenoh {
        what,
        detail: e.to_string(),
    }
}

pub fn local_err<E: fmt::Debug>(what: impl Into<String>) -> impl FnOnce(E) -> LinkError {
    let what = what.into();
    move |e| LinkError::Local {
        what,
        detail: format!("{e:?}"),
    }
}

/// Where a half meets the other: endpoints it listens on and connects
/// to (Zenoh locators, `tcp/HOST:PORT`). Multicast scouting is off: a
/// link joins exactly what it is told, so that two links on one network
/// never meet by accident.
#[derive(Debug, Clone, Default)]
pub struct Endpoints {
    pub listen: Vec<String>,
    pub connect: Vec<String>,
}

/// A Zenoh session in peer mode on `endpoints`.
pub fn open(endpoints: &Endpoints) -> Result<zenoh::Session, LinkError> {
    let mut config = zenoh::Config::default();
    let list = |v: &[String]| {
        let quoted: Vec<String> = v.iter().map(|e| format!("{e:?}")).collect();
        format!("[{}]", quoted.join(","))
    };
    let set = |config: &mut zenoh::Config, key: &str, value: String| {
        config
            .insert_json5(key, &value)
            .map_err(zenoh_err(format!("config {key} = {value}")))
    };
    set(&mut config, "mode", "\"peer\"".into())?;
    set(&mut config, "scouting/multicast/enabled", "false".into())?;
    set(&mut config, "listen/endpoints", list(&endpoints.listen))?;
    set(&mut config, "connect/endpoints", list(&endpoints.connect))?;
    // A connect endpoint that is not up yet is retried (the two halves
    // may start in any order).
    set(&mut config, "connect/timeout_ms", "-1".into())?;
    zenoh::open(config)
        .wait()
        .map_err(zenoh_err("cannot open a session"))
}

/// The endpoints an importer connects to: those listened on, with a
/// wildcard address named as this host's loopback (a remote host puts its
/// address for this host's there).
pub fn listening(endpoints: &Endpoints) -> Vec<String> {
    endpoints
        .listen
        .iter()
        .map(|e| {
            e.replace("/0.0.0.0:", "/127.0.0.1:")
                .replace("/[::]:", "/[::1]:")
        })
        .collect()
}

/// The keys of server `name`'s link.
#[derive(Debug, Clone)]
pub struct Keys {
    root: String,
}

impl Keys {
    pub fn new(name: &str) -> Result<Keys, LinkError> {
        let root = format!("cosim/{name}/link");
        zenoh::key_expr::KeyExpr::try_from(format!("{root}/state"))
            .map_err(|_| LinkError::BadName(name.into()))?;
        if name.is_empty() || name.contains(['*', '$', '#', '?']) {
            return Err(LinkError::BadName(name.into()));
        }
        Ok(Keys { root })
    }
    /// The exporter's frames, to every importer.
    pub fn state(&self) -> String {
        format!("{}/state", self.root)
    }
    /// What importer `zid` sends (inputs, requests, gone clients).
    pub fn up(&self, zid: &str) -> String {
        format!("{}/up/{zid}", self.root)
    }
    /// Every importer's `up`.
    pub fn up_all(&self) -> String {
        format!("{}/up/*", self.root)
    }
    /// What the exporter sends importer `zid` (responses).
    pub fn down(&self, zid: &str) -> String {
        format!("{}/down/{zid}", self.root)
    }
    /// The exporter's hello: the scene's sizes and the newest frame.
    pub fn hello(&self) -> String {
        format!("{}/hello", self.root)
    }
    /// The exporter's liveliness token.
    pub fn exporter(&self) -> String {
        format!("{}/exporter", self.root)
    }
    /// Importer `zid`'s liveliness token.
    pub fn importer(&self, zid: &str) -> String {
        format!("{}/importer/{zid}", self.root)
    }
    /// Every importer's token.
    pub fn importer_all(&self) -> String {
        format!("{}/importer/*", self.root)
    }
    /// The importer of a token's key.
    pub fn importer_of<'a>(&self, key: &'a str) -> Option<&'a str> {
        key.strip_prefix(&self.root)?.strip_prefix("/importer/")
    }
    /// The importer of an `up` key.
    pub fn up_of<'a>(&self, key: &'a str) -> Option<&'a str> {
        key.strip_prefix(&self.root)?.strip_prefix("/up/")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_name_their_server_and_peer() {
        let k = Keys::new("arm-1").expect("a fine name");
        assert_eq!(k.state(), "cosim/arm-1/link/state");
        assert_eq!(k.importer_of(&k.importer("abc")), Some("abc"));
        assert_eq!(k.up_of(&k.up("abc")), Some("abc"));
        assert_eq!(k.importer_of(&k.up("abc")), None);
        for bad in ["", "a*b", "x/$y", "q?", "a//b"] {
            assert!(Keys::new(bad).is_err(), "{bad:?} was taken");
        }
    }
}
