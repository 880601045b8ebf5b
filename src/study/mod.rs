//! Measuring what accuracy costs: image comparison, convergence studies, their tables and
//! plots.
//!
//! - [`compare`]: error norms, per-pixel and block z-tests and difference images of two
//!   images (`brume compare`).
//! - [`run`]: configurations (estimators, majorants, adaptive sampling), the reference render
//!   and per-pass checkpoints (`brume study`).
//! - [`report`]: per-configuration summaries (RMSE at the budget, time to a target, TTUV,
//!   inverse efficiency, fixed against adaptive sampling), the CSV, Markdown and JSON outputs.
//! - [`plot`]: RMSE-versus-time and efficiency plots (PNG and SVG).
//! - [`stats`]: normal quantiles, the Sidak correction, least-squares lines.
pub mod compare;
pub mod plot;
pub mod report;
pub mod run;
pub mod stats;

pub use compare::{compare, CompareError, CompareOptions, Comparison, ZTest};
pub use report::{summarize, AdaptiveGain, ConfigSummary, StudySummary};
pub use run::{
    default_sweep, render_config, run_config, AdaptiveSampling, Checkpoint, StudyConfig,
};
