//! The GVS backend: the faces guided visibility sampling found visible from the eye's view cell
//! ([`GvsCells`]), frustum-culled per face box and sorted front to back by the distance from the
//! eye to the face box. **Aggressive, not conservative**: sampling can leave out a face of which a
//! few pixels show.
//!
//! [`Gvs`], the value in [`super::all`], answers with the cells the world was loaded with
//! ([`World::gvs_cells`]).
//!
//! # Conventions
//! - The eye's cell, and what a cell lists, are as in [`crate::gvs_cells`].
//! - `Visible::leaves` stays empty: GVS cells are not leaves. `Visible::faces` holds face indices of
//!   the level, each once; with [`View::cull_back_faces`] the back faces are dropped after the
//!   query ([`World::cull_back_faces`]).

use crate::backend::api::Backend;
use crate::camera::View;
use crate::gvs_cells::GvsCells;
use crate::scratch::{FrameStats, Scratch, Visible};
use crate::world::World;

/// True when `cells` can answer for `world`: it has cells, made for a level with its face count.
fn fits(cells: &GvsCells, world: &World) -> bool {
    !cells.is_empty() && world.num_faces() == cells.num_faces()
}

/// The frame of the backend; back faces (when the view asks) are dropped from the sorted
/// list, since no walk outputs these faces.
fn cull_cells(world: &World, cells: &GvsCells, view: &View, scratch: &mut Scratch, out: &mut Visible) {
    out.leaves.clear();
    cells.query(view.eye, &view.frustum, &mut out.faces);
    if view.cull_back_faces {
        world.cull_back_faces(view.eye, &mut out.faces);
    }
    scratch.stats = FrameStats::default();
}

/// The GVS backend over the cells a [`World`] carries ([`World::gvs_cells`]); this is the value in
/// [`super::all`]. It supports a world loaded from a level with GVS cells; on any other world it
/// outputs nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Gvs;

impl Backend for Gvs {
    fn name(&self) -> &'static str {
        "gvs"
    }

    fn supports(&self, world: &World) -> bool {
        world.gvs_cells().is_some_and(|c| fits(c, world))
    }

    /// False: GVS finds a cell's faces by sampling rays, so a face no sample reached is left out
    /// even where a few pixels of it show (the thesis' pixel error).
    fn conservative(&self) -> bool {
        false
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        match world.gvs_cells() {
            Some(cells) => cull_cells(world, cells, view, scratch, out),
            None => {
                out.clear();
                scratch.stats = FrameStats::default();
            }
        }
    }
}
