//! Culling backends behind one small interface, so an engine can switch at run time.
//!
//! Every backend takes a [`World`], a [`View`] and the caller's [`Scratch`], and fills a
//! [`Visible`] with leaves and faces, front to back. Backends:
//! - [`pvs::Pvs`] (the default): the eye cluster's PVS (a pruned tree built at load), then the
//!   frustum walk.
//! - [`portal::Portal`]: nothing precomputed; recursion through the level's portals, narrowing the
//!   frustum at each portal polygon, then the same frustum walk over the leaves it reached.
//! - [`gvs::WorldGvs`]: the faces of the eye's GVS view cell, from the cells the world was loaded
//!   with ([`World::gvs`]); it supports only worlds whose level has GVS cells, and outputs faces
//!   but no leaves.

pub mod gvs;
pub mod portal;
pub mod pvs;

use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::world::World;

/// A culling strategy. Implementations hold no per-frame state: everything mutable lives in the
/// caller's [`Scratch`], so one backend value serves every thread.
pub trait Backend: Send + Sync + std::fmt::Debug {
    /// Short lowercase name (`"pvs"`, `"portal"`, ...), used by the CLI, the C ABI and reports.
    fn name(&self) -> &'static str;

    /// True when this backend can answer for `world` (the portal backend needs portals).
    fn supports(&self, world: &World) -> bool;

    /// Fill `out` (cleared first) with what `view` may see, front to back.
    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible);
}

/// Every backend, default first (check [`Backend::supports`] for a given world).
pub fn all() -> &'static [&'static dyn Backend] {
    &[&pvs::Pvs, &portal::Portal, &gvs::WorldGvs]
}

/// The backend called `name`.
pub fn by_name(name: &str) -> Option<&'static dyn Backend> {
    all().iter().copied().find(|b| b.name() == name)
}
