//! senc-train: scenes, the two-phase autoregressive trainer and Table-1 evaluation.
//!
//! It will own scene configs (garment, body, motion, material, external force, holes to
//! close), the training loop with HOOD's schedule and SENC's two phases, checkpoints with
//! resume, and the evaluation metrics. Not built yet: see issues 5 and 7.
