//! `sightline-runtime`: load a compiled level and answer, every frame, what can be seen.
//!
//! ```no_run
//! use sightline_runtime::{Camera, Scratch, Visible, World, backend::{Backend, pvs::Pvs}};
//! # fn frame(world: &World, cam: &Camera) {
//! let mut scratch = Scratch::new(world);
//! let mut visible = Visible::for_world(world);
//! Pvs.cull(world, &cam.view(), &mut scratch, &mut visible);
//! for &leaf in &visible.leaves { /* draw front to back */ }
//! # }
//! ```
//!
//! A [`World`] is validated once at load ([`World::new`], [`load::load_slvl`], [`load::load_bsp`], [`load::load_path`]);
//! afterwards no query can panic. It is immutable and `Send + Sync`; per-caller state lives in a
//! [`Scratch`], so culling allocates nothing per frame.

#![deny(unsafe_code)]

// Layers, bottom up (a module imports only from layers below it):
// 1. `error`, `camera`: no crate imports.
// 2. `tree` (the level's validated tables), `gvs_cells` (the level's GVS cells).
// 3. `locate`, `layout`, `draw` (built from `tree`); then `pvs` (rows, PHS, per-cluster trees
//    over `layout`).
// 4. `world`: owns all of the above; knows no query module and no backend.
// 5. `scratch`, `trace`, `load`, `query`; then `walk`; then `backend::*`; then `check`, `poses`, `synth`
//    (feature `testkit`) and `ffi` (feature `ffi`).

pub mod backend;
pub mod camera;
#[cfg(any(test, feature = "testkit"))]
pub mod check;
pub mod draw;
pub mod error;
#[cfg(feature = "ffi")]
#[allow(unsafe_code)]
pub mod ffi;
pub mod gvs_cells;
pub(crate) mod layout;
pub mod load;
pub(crate) mod locate;
#[cfg(any(test, feature = "testkit"))]
pub mod poses;
pub mod pvs;
pub mod query;
pub mod scratch;
#[cfg(any(test, feature = "testkit"))]
pub mod synth;
pub mod trace;
pub(crate) mod tree;
pub mod walk;
pub mod world;

pub use camera::{Camera, ClipDepth, Frustum, View};
pub use draw::{BrushModel, DrawData, FaceView};
pub use error::{GvsError, LoadError};
pub use gvs_cells::GvsCells;
pub use pvs::Bitset;
pub use scratch::{FrameStats, Scratch, Visible};
pub use trace::TraceHit;
pub use world::{Bounds, LeafId, World};

#[cfg(test)]
mod tests;

/// `docs/engine.md`, the engine integration guide, included so that its Rust snippets run as
/// doctests (they build small levels with `synth`, hence `testkit`).
#[cfg(all(doctest, feature = "testkit"))]
#[doc = include_str!("../../docs/engine.md")]
pub struct EngineGuide;
