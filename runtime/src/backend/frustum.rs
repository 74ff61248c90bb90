//! The frustum-only backend: the walk over every open leaf ([`Marks::ALL`]), so the output is
//! every leaf whose box meets the view frustum and its faces, front to back, with no visibility
//! information at all. Conservative: it outputs a superset of the PVS backend's leaves (the PVS
//! walk is the same walk over a subset of the leaves).
//!
//! `FrameStats::marked_leaves` is the number of open leaves.

use crate::backend::api::Backend;
use crate::camera::View;
use crate::scratch::{FrameStats, Scratch, Visible};
use crate::walk::{Marks, walk};
use crate::world::World;

/// The frustum-only backend; see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrustumOnly;

impl Backend for FrustumOnly {
    fn name(&self) -> &'static str {
        "frustum"
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        scratch.stats =
            FrameStats { marked_leaves: world.open_leaves().len() as u32, ..FrameStats::default() };
        walk(world, view, Marks::ALL, scratch, out);
    }
}
