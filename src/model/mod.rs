//! The bee model of paper 000, one file per force, and the baselines.
pub mod params;
pub use params::BeeParams;
