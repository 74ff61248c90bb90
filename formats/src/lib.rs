//! Sightline's shared vocabulary: geometry primitives, bit rows (`bits`, as PVS rows are held in
//! memory), the level data model, and every on-disk
//! format (`.map`, `.obj`, `.prt`, Quake BSP29/BSP2, the Quake PVS RLE, and `.slvl`).
//!
//! Readers never panic on hostile input and never allocate more than the input can justify: every
//! count read from a file is checked against the bytes that remain before anything is allocated.
//! Text formats report `file:line:col`, binary formats a byte offset.

pub mod atomic;
pub mod bits;
pub mod bsp;
pub mod geom;
mod le;
pub mod level;
pub mod map;
pub mod obj;
pub mod prt;
pub mod rle;
pub mod rng;
pub mod shared_maps;
pub mod slvl;
#[cfg(test)]
mod test_support;
mod tree_check;

pub use geom::{Aabb, Plane, PlaneKind, PlaneSet, Side, Split, Winding};
pub use level::{Contents, Face, GvsCell, Leaf, Level, LevelPlane, Model, Node, Portal};
