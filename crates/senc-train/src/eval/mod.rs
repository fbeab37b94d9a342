//! Evaluation: the paper's Table-1 metrics on the test motions ([`table1`]), with the
//! reference solver as a row of its own, and the error against run time of the reference
//! solver and the network ([`runtime`]), written as Markdown, CSV, JSON and an SVG plot
//! ([`report`], [`plot`]); the one-step probe on training states ([`probe`]).
//!
//! A method with [`Method::refine`] > 0 is rolled out with each frame refined by Newton
//! (`rollout::network_rollout`), so its Table-1 row measures the hybrid simulator.

pub mod method;
pub mod plot;
pub mod probe;
pub mod report;
pub mod runtime;
pub mod table1;

pub use method::{first_scene, training_config, Method, Predictor, Scenario, SOLVER_LABEL};
pub use probe::{one_step_probe, ProbeRow};
pub use report::{write_reports, MarkdownTable};
pub use runtime::{CurvePoint, Series};
pub use table1::{evaluate, evaluate_solver, Row, VolumeMeter, RISE_FRAME};
