//! The no-culling backend: every open leaf and every face of those leaves, whatever the view
//! (the culling thesis' "no culling" baseline; what an engine without any culling would submit).
//!
//! # Conventions
//! - `Visible::leaves` lists [`World::open_leaves`] in their order (not front to back: nothing
//!   is sorted); `Visible::faces` their faces, each once, in the order of their first leaf; with
//!   [`View::cull_back_faces`] the back faces are dropped ([`World::cull_back_faces`]).
//! - `FrameStats::marked_leaves` is the number of open leaves; the walk's counters are 0.

use crate::backend::api::Backend;
use crate::camera::View;
use crate::scratch::{FrameStats, Scratch, Visible};
use crate::world::World;

/// The no-culling backend; see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoCulling;

impl Backend for NoCulling {
    fn name(&self) -> &'static str {
        "none"
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        scratch.bind(world);
        out.clear();
        let frame = scratch.walk.next_frame_gen();
        for &leaf in world.open_leaves() {
            out.leaves.push(leaf);
            for &f in world.leaf_faces(leaf) {
                if let Some(m) = scratch.walk.face_mark.get_mut(f as usize)
                    && *m != frame
                {
                    *m = frame;
                    out.faces.push(f);
                }
            }
        }
        if view.cull_back_faces {
            world.cull_back_faces(view.eye, &mut out.faces);
        }
        scratch.stats = FrameStats { marked_leaves: out.leaves.len() as u32, ..FrameStats::default() };
    }
}
