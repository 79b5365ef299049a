//! Realism you can measure: evaluation of simulated flights against recorded insect
//! flights (paper 000 Sec. VI/VIII, paper 002 "Model Evaluation"), and calibration of
//! the model's parameters with a genetic algorithm. See docs/validation.md.

pub mod calibrate;
pub mod cli;
pub mod collective;
pub mod figure;
pub mod ga;
pub mod histogram;
pub mod metrics;
pub mod report;
pub mod resample;
pub mod tracks;

pub use calibrate::{CalibrateArgs, run_calibrate};
pub use cli::{EvalArgs, run_eval};
