//! Quake `.map` files: Standard and Valve 220 brush formats.
//!
//! A side's plane comes from its three points as `normalize((p0 - p1) × (p2 - p1))` and faces out
//! of the brush (see [`crate::geom`]); the brush is the intersection of the half-spaces behind its
//! planes.

use glam::DVec3;

use crate::geom::Plane;

/// Which brush-side syntax the file uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// `( p1 ) ( p2 ) ( p3 ) TEX xoff yoff rot xscale yscale`.
    Standard,
    /// `( p1 ) ( p2 ) ( p3 ) TEX [ ux uy uz uoff ] [ vx vy vz voff ] rot xscale yscale`.
    Valve220,
}

/// Texture placement of a side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TexAxes {
    /// Standard: offsets, rotation in degrees, scales.
    Standard {
        /// Offset along the projected s and t axes.
        offset: [f64; 2],
        /// Rotation in degrees.
        rotation: f64,
        /// Scale along s and t.
        scale: [f64; 2],
    },
    /// Valve 220: explicit axes with offsets, rotation and scales.
    Valve {
        /// s axis and offset.
        u: [f64; 4],
        /// t axis and offset.
        v: [f64; 4],
        /// Rotation in degrees (informational in this format).
        rotation: f64,
        /// Scale along s and t.
        scale: [f64; 2],
    },
}

/// One side of a brush.
#[derive(Debug, Clone, PartialEq)]
pub struct BrushSide {
    /// The three points as written.
    pub points: [DVec3; 3],
    /// The plane through them, facing out of the brush.
    pub plane: Plane,
    /// Texture name (decides contents: `*water`, `sky`, `clip`, ...).
    pub texture: String,
    /// Texture placement.
    pub axes: TexAxes,
    /// 1-based line of the side in the file.
    pub line: u32,
}

/// A convex brush.
#[derive(Debug, Clone, PartialEq)]
pub struct Brush {
    /// Its sides, at least four.
    pub sides: Vec<BrushSide>,
    /// 1-based line of the opening brace.
    pub line: u32,
}

/// An entity: key/value pairs in file order and its brushes.
#[derive(Debug, Clone, PartialEq)]
pub struct Entity {
    /// Key/value pairs in file order.
    pub properties: Vec<(String, String)>,
    /// Brushes (empty for point entities).
    pub brushes: Vec<Brush>,
    /// 1-based line of the opening brace.
    pub line: u32,
}

impl Entity {
    /// The value of `key`, if present (the last one wins when repeated, as Quake does).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.properties.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The `classname`, or `""`.
    pub fn classname(&self) -> &str {
        self.get("classname").unwrap_or("")
    }

    /// The `origin` key parsed as three finite numbers, if present and well formed.
    pub fn origin(&self) -> Option<DVec3> {
        let mut it = self.get("origin")?.split_whitespace().map(|t| t.parse::<f64>().ok());
        let v = DVec3::new(it.next()??, it.next()??, it.next()??);
        v.is_finite().then_some(v)
    }
}

/// A parsed `.map` file; `entities[0]` is `worldspawn`.
#[derive(Debug, Clone, PartialEq)]
pub struct MapFile {
    /// Entities in file order.
    pub entities: Vec<Entity>,
    /// The brush syntax found.
    pub format: MapFormat,
}
