//! The energy terms. Each is a type whose doc comment gives its formula, units and domain;
//! each evaluates `E(x)` in joules for the predicted positions `x = x[t+1]` and adds
//! `∂E/∂x` (newtons, J/m) into a gradient buffer when one is given.

pub mod bending;
pub mod body;
pub mod gravity;
pub mod inertia;
pub mod repulsion;
pub mod self_collision;
pub mod stretching;
