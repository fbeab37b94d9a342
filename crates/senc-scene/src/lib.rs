//! senc-scene: everything between the registry data and a simulation input, without burn.
//!
//! Skeletons and linear blend skinning ([`skeleton`]), BVH motion capture parsing,
//! resampling and retargeting by joint name ([`bvh`], [`motion`]), motions from files by
//! name or path ([`clip`]), the committed body and
//! garment assets ([`assets`]), the garment building steps ([`build`]), the joining of two
//! open parts along a boundary loop each ([`zipper`]), the fit of garments made
//! elsewhere, with mesh repair ([`fit`]), TOML scene configs
//! with a train/test motion split ([`config`], [`scene`]) and a software rasteriser for
//! preview pictures ([`raster`]).
//!
//! Units: metres, seconds, radians inside (BVH files carry degrees); Y up; the body faces +z.
//! This crate depends on senc-geom only among ours and never on burn, so data tools build in
//! seconds.

// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod assets;
pub mod build;
pub mod bvh;
pub mod clip;
pub mod config;
pub mod error;
pub mod fit;
pub mod motion;
pub mod raster;
pub mod scene;
pub mod skeleton;
pub mod zipper;

pub use assets::{BodyAsset, GarmentAsset, NamedLoop};
pub use bvh::Bvh;
pub use clip::JointMap;
pub use config::SceneConfig;
pub use error::SceneError;
pub use motion::Motion;
pub use scene::{InitialState, Scene, Split};
pub use senc_geom::BodyQuery;
pub use skeleton::{skin, Bone, Pose, Skeleton, SkinWeights};
