//! How a cosim state is shown in Foxglove: the scene drawn as Foxglove
//! messages (`draw`), the channels' schemas (`schema`), the body colours
//! shared with the figures (`palette`), MCAP recordings (`record`), and a
//! live Foxglove WebSocket server (`live`) for `cosim view`; the bodies'
//! looks, sent once (`visuals`).
//!
//! No iceoryx2 and no engine: the recordings (`cosim-server run --mcap`)
//! draw from a run's files, the live view from the state frames it reads
//! as a monitor.

pub mod draw;
pub mod live;
pub mod palette;
pub mod record;
pub mod schema;
pub mod visuals;

pub use draw::{Arrow, Drawing, Pose};
pub use live::{Channel, Live};
