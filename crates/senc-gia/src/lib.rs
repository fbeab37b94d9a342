//! senc-gia: Global Intersection Analysis and the differentiable penetration volume.
//!
//! It will own intersection paths, loop vertices, the parallel flood fill and the penetration
//! volume with its gradient. Not built yet: see issue 3.
