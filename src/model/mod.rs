//! The bee model of paper 000, one file per force, and the baselines.
//!
//! Every function here returns accelerations (m/s²) or velocities (m/s) in the world frame
//! unless it says otherwise.
pub mod boids;
pub mod brownian;
pub mod collision;
pub mod kernels;
pub mod oscillation;
pub mod params;
pub mod repulsion;
pub mod targets;
pub mod vision;

pub use params::BeeParams;
