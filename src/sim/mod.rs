//! The simulation: world state, stepping, neighbour grid, and what is recorded.
pub mod agent_bytes;
pub mod frame;
pub mod skin;

pub mod world;

pub use frame::{CacheMeta, Frame, SwarmFrame, SwarmMeta};
pub use world::Simulation;
