//! Controllers on other hosts in lockstep with a `cosim-server`, over
//! Zenoh (docs/remote.md). Two halves: `export` beside the server, which
//! plays each remote client to it through a proxy of its own, and
//! `import` beside the controllers, which holds the server's services
//! there, so that any client of docs/protocol.md runs unchanged.

pub mod bench;
pub mod export;
pub mod message;
pub mod mirror;
pub mod session;
