//! Map → level: CSG, leafy BSP, portals, outside fill and leaks, and the emitted [`Level`](sightline_formats::Level).
//!
//! [`compile`](fn@compile) runs the phases in order: `csg` (brush windings, contents, face clipping), `bsp`
//! (brush BSP of the world, detail last; one per submodel), `portals`, `outside` (flood from the
//! void, leak check, fill), `emit` (level and `.prt`), and `vis` when asked ([`vis`], then the
//! rows are stored Quake-RLE per cluster by [`store_pvs`]; [`visdata`] also stores them in Quake
//! `.bsp` and `.vis` files). Output is identical for any thread count:
//! parallel steps collect in input order and tree building uses `rayon::join` only.

mod brush;
mod bsp;
pub mod bsp_portals;
mod compile;
pub mod contents;
mod csg;
pub mod dropin;
mod emit;
mod error;
mod layers;
mod load;
pub mod memory;
pub mod mesh;
mod options;
mod outside;
pub mod phase_memory;
pub mod phs;
mod portals;
mod prepared;
mod report;
mod source;
pub mod vis;
mod viscluster;
pub mod visdata;

#[cfg(test)]
mod limit_tests;

pub use sightline_job::progress::{NoProgress, Progress};

pub use brush::MAX_BRUSH_SIDES;
pub use compile::compile;
pub use error::CompileError;
pub use options::CompileOptions;
pub use prepared::OUTSIDE_MARGIN;
pub use report::{Compiled, LeakReport, POINTFILE_STEP, PhaseTime, Stats};
pub use source::{Source, SourceError};
pub use viscluster::VisClusterStat;
pub use visdata::store_pvs;
