//! Spatial fields: gradient noise and the curl-noise force built from it.
pub mod curl;
pub mod noise;
pub use curl::CurlNoise;
