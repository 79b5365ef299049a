//! beeswarm: honeybee swarm simulation after Chen et al., "A Bio-inspired Model for Bee
//! Simulations" (paper 000), baked to glTF 2.0, USDA and CSV caches.
//!
//! Conventions everywhere: metres, seconds, world Y-up right-handed; quaternions are
//! glam `Quat` (x, y, z, w) body → world; body X forward, Y up, Z right.

// A shot error carries its file, place and source line; it is built at most once per
// failed run, so boxing it to shrink `Result` would buy nothing.
#![allow(clippy::result_large_err)]

pub mod atomic;
pub mod bake;
pub mod cache_set;
pub mod checkpoint;
pub mod cli;
pub mod error;
pub mod export;
pub mod field;
pub mod geometry;
pub mod math;
pub mod model;
pub mod shot;
pub mod sim;
pub mod simd;
pub mod species;
pub mod wedge;

pub use error::{Error, Result};
pub mod eval;
pub mod plot;
pub mod progress;
