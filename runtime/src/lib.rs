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

pub mod backend;
pub mod bvh;
pub mod camera;
pub mod check;
pub mod error;
#[cfg(feature = "ffi")]
#[allow(unsafe_code)]
pub mod ffi;
pub(crate) mod layout;
pub mod load;
pub mod locate;
pub mod poses;
pub mod pvs;
pub mod scratch;
pub mod synth;
pub mod trace;
pub mod walk;
pub mod world;

pub use camera::{Camera, ClipDepth, Frustum, View};
pub use error::LoadError;
pub use pvs::Bitset;
pub use scratch::{FrameStats, Scratch, Visible};
pub use trace::TraceHit;
pub use world::{Bounds, LeafId, World};

#[cfg(test)]
mod tests;
