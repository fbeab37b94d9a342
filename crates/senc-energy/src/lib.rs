//! senc-energy: cloth energies with analytic gradients, and a reference solver.
//!
//! It will own StVK stretching, discrete-shell bending, inertia, gravity and external force,
//! body collision, friction, the self-collision terms (penetration volume from senc-gia, the
//! area and repulsive baselines), scene-driven assembly, and a Newton / L-BFGS reference
//! solver. Not built yet: see issue 4.
