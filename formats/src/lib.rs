//! Sightline's shared vocabulary: geometry primitives, bit rows (`bits`, as PVS rows are held in
//! memory and in files), the level data model, the texture-name rules (`texture`), and every
//! on-disk format (`.map`, `.obj`, `.prt`, Quake BSP29/BSP2, the Quake PVS RLE, `.slvl` and the
//! `.vis` file, and the external `.vis` files engines load beside a map: `vispatch`), with `kind`
//! telling them apart.
//!
//! The `.map` parser (`map`), the `.obj` loader (`obj`) and the reader of ericw-tools'
//! `NAME.texinfo.json` (`texinfo_json`) are behind the features of the same names; telling those
//! files apart (`kind`) needs none of them.
//!
//! Readers never panic on hostile input and never allocate more than the input can justify: every
//! count read from a file is checked against the bytes that remain before anything is allocated.
//! Text formats report `file:line:col`, binary formats a byte offset.

pub mod bits;
pub mod bsp;
mod decimal;
pub mod entities;
pub mod geom;
pub mod hash;
pub mod kind;
mod le;
pub mod level;
mod lexer;
#[cfg(feature = "map")]
pub mod map;
#[cfg(feature = "obj")]
pub mod obj;
pub mod prt;
pub mod rle;
pub mod slvl;
#[cfg(all(test, any(feature = "map", feature = "obj")))]
mod test_support;
#[cfg(feature = "texinfo_json")]
pub mod texinfo_json;
pub mod texture;
mod tree_check;
pub mod visfile;
pub mod vispatch;

pub use geom::{Aabb, Plane, PlaneKind, PlaneSet, Side, Split, Winding};
pub use kind::FileKind;
pub use level::{Contents, Face, FaceDraw, GvsCell, Leaf, Level, LevelPlane, Model, Node, Portal};
