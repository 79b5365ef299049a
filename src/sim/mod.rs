//! The simulation: world state, stepping, neighbour grid, and what is recorded.
pub mod frame;
pub use frame::{CacheMeta, Frame, SwarmFrame, SwarmMeta};
pub mod obstacle;
