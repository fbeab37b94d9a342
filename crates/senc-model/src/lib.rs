//! senc-model: the self-collision-aware graph neural network of SENC (section 3.1), in burn.
//!
//! It will own the graph (cloth and body nodes; mesh, body and radius-graph self-collision
//! edges), the feature normalisers, the encoder / message-passing / decoder network, the
//! checkpoint format, and the one place where f64 geometry becomes f32 tensors. It will be the
//! lowest crate that depends on burn. Not built yet: see issue 6.
