//! Spatial fields: gradient noise and the curl-noise force built from it.
pub mod curl;
pub mod noise;
mod wide;
pub use curl::CurlNoise;
