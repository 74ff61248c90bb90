//! Culling backends behind one small interface, so an engine can switch at run time.
//!
//! Every backend takes a [`World`](crate::World), a [`View`](crate::View) and the caller's
//! [`Scratch`](crate::Scratch), and fills a [`Visible`](crate::Visible) with leaves and faces,
//! front to back. Backends:
//! - [`none::NoCulling`] (`none`): every open leaf and its faces, whatever the view (the
//!   baseline).
//! - [`frustum::FrustumOnly`] (`frustum`): the frustum walk over every open leaf, no visibility.
//! - [`pvs::Pvs`] (the default): the eye cluster's PVS (a pruned tree built at load), then the
//!   frustum walk.
//! - [`portal::Portal`]: nothing precomputed; recursion through the level's portals, narrowing the
//!   frustum at each portal polygon, then the same frustum walk over the leaves it reached.
//! - [`gvs::Gvs`]: the faces of the eye's GVS view cell, from the cells the world was loaded
//!   with ([`World::gvs_cells`](crate::World::gvs_cells)); it supports only worlds whose level has
//!   GVS cells, and outputs faces but no leaves.
//! - [`raycast::RayCast`]: a sparse grid of rays through the tree marks the leaves they reach, then
//!   the same frustum walk; **aggressive** (may hide what lies between its rays,
//!   [`Backend::conservative`] is false), and it falls back to the PVS backend when that is cheaper.
//!
//! Backends sit on top of the world: they read it through its public queries and crate-internal
//! read-only views, and the world knows none of them. A new backend is a module here implementing
//! [`Backend`] (and an entry in [`all`] to be offered by name).

mod api;
pub mod frustum;
pub mod gvs;
pub mod none;
pub mod portal;
pub mod pvs;
pub mod raycast;

pub use api::Backend;

/// Every backend, default first (check [`Backend::supports`] for a given world).
pub fn all() -> &'static [&'static dyn Backend] {
    &[
        &pvs::Pvs,
        &portal::Portal,
        &gvs::Gvs,
        &raycast::RayCast::DEFAULT,
        &frustum::FrustumOnly,
        &none::NoCulling,
    ]
}

/// The backend called `name`.
pub fn by_name(name: &str) -> Option<&'static dyn Backend> {
    all().iter().copied().find(|b| b.name() == name)
}
