//! Quake `.map` files: Standard and Valve 220 brush formats.
//!
//! A side's plane comes from its three points as `normalize((p0 - p1) × (p2 - p1))` and faces out
//! of the brush (see [`crate::geom`]); the brush is the intersection of the half-spaces behind its
//! planes.
//!
//! [`parse`] reads the text with Quake's tokenizing rules (`crate::lexer`, shared with
//! [`crate::entities`]), decides each side's syntax
//! on its own, and rejects anything a compiler could not use, with `file:line:col` and the entity,
//! brush and side (0-based, file order) in the [`MapError`]. Parsing never panics and allocates only
//! what the text justifies (every entity, brush and side consumes tokens of the text).
//!
//! # Bytes and text
//! Quake's tools read a `.map` as bytes: any byte `>= 0x80` may appear, typically in entity
//! strings (`message` keys in Quake's coloured "gold" characters). [`decode`] turns a file's bytes
//! into text without ever failing: bytes that are valid UTF-8 are that text (so every UTF-8 map
//! parses exactly as before); any other file is read as Latin-1, each byte becoming the character
//! with the same code (`0xE9` → `U+00E9`). Every byte survives: a string of the map becomes a Rust
//! `String` (UTF-8, so a byte `>= 0x80` takes two bytes there, for example in the entity text of
//! a compiled level), and [`encode_latin1`] gives the file's bytes back. [`parse_bytes`] is
//! [`decode`] then [`parse`], what every reader of `.map` files should call.

use glam::DVec3;

use crate::geom::{Aabb, ON_EPSILON, Plane, WORLD_LIMIT, Winding};
use crate::lexer::{Lexer, Token, Unterminated};

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

/// Quake's six texture base axes (qbsp's `baseaxis`): a face normal, then the s and t axes a
/// Standard side projects onto, for floor, ceiling, west, east, south and north walls.
const BASE_AXES: [[[f64; 3]; 3]; 6] = [
    [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]],
    [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]],
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
    [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
    [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
];

impl TexAxes {
    /// The s and t texture vectors of a side whose plane normal (out of the brush) is `normal`,
    /// as Quake's qbsp computes a texinfo: `s = v[0][0..3] · p + v[0][3]` texels for a point
    /// `p`, likewise `t` with `v[1]`. Standard sides project onto the base axis closest to the
    /// normal (the first of floor, ceiling, west, east, south, north on ties), rotated by
    /// `rotation` degrees and divided by the scales; Valve 220 sides give their axes directly.
    /// A zero scale counts as 1, as in qbsp.
    pub fn vectors(&self, normal: DVec3) -> [[f64; 4]; 2] {
        let unit = |s: f64| if s == 0.0 { 1.0 } else { s };
        match *self {
            TexAxes::Valve { u, v, scale, .. } => {
                let axis = |a: [f64; 4], s: f64| [a[0] / unit(s), a[1] / unit(s), a[2] / unit(s), a[3]];
                [axis(u, scale[0]), axis(v, scale[1])]
            }
            TexAxes::Standard { offset, rotation, scale } => {
                let mut best = 0;
                let mut best_dot = 0.0;
                for (i, base) in BASE_AXES.iter().enumerate() {
                    let d = normal.dot(DVec3::from(base[0]));
                    if d > best_dot {
                        best_dot = d;
                        best = i;
                    }
                }
                let mut vecs = [BASE_AXES[best][1], BASE_AXES[best][2]];
                // Exact quarter turns, as qbsp, so axial textures stay exact.
                let quarter =
                    [(0.0, (0.0, 1.0)), (90.0, (1.0, 0.0)), (180.0, (0.0, -1.0)), (270.0, (-1.0, 0.0))];
                let (sinv, cosv) = quarter
                    .iter()
                    .find(|(r, _)| *r == rotation)
                    .map_or_else(|| rotation.to_radians().sin_cos(), |&(_, sc)| sc);
                let first_nonzero = |v: [f64; 3]| v.iter().position(|&c| c != 0.0).unwrap_or(2);
                let (sv, tv) = (first_nonzero(vecs[0]), first_nonzero(vecs[1]));
                for v in &mut vecs {
                    let (ns, nt) = (cosv * v[sv] - sinv * v[tv], sinv * v[sv] + cosv * v[tv]);
                    v[sv] = ns;
                    v[tv] = nt;
                }
                let axis = |v: [f64; 3], s: f64, o: f64| [v[0] / unit(s), v[1] / unit(s), v[2] / unit(s), o];
                [axis(vecs[0], scale[0], offset[0]), axis(vecs[1], scale[1], offset[1])]
            }
        }
    }
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

impl Brush {
    /// The polygon of each side: a huge square on the side's plane clipped behind every other
    /// side (with [`ON_EPSILON`]); `None` for a side that does not touch the brush's surface.
    pub fn windings(&self) -> Vec<Option<Winding>> {
        self.sides
            .iter()
            .enumerate()
            .map(|(i, side)| {
                let mut w = Winding::base_for_plane(&side.plane);
                for (j, other) in self.sides.iter().enumerate() {
                    if j != i {
                        w = w.clip(&other.plane.flipped(), ON_EPSILON, false)?;
                    }
                }
                Some(w)
            })
            .collect()
    }

    /// The box around the brush's corners ([`Aabb::EMPTY`] when the sides enclose nothing).
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for w in self.windings().into_iter().flatten() {
            b = b.union(&w.bounds());
        }
        b
    }
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

impl MapFile {
    /// Every brush of every entity, in file order.
    pub fn brushes(&self) -> impl Iterator<Item = &Brush> {
        self.entities.iter().flat_map(|e| &e.brushes)
    }

    /// The box around every brush of every entity ([`Aabb::EMPTY`] without brushes).
    pub fn bounds(&self) -> Aabb {
        self.brushes().fold(Aabb::EMPTY, |b, brush| b.union(&brush.bounds()))
    }
}

/// Where in the brush structure an error happened: entity index, brush index within the entity and,
/// when known, the side index within the brush (all 0-based, in file order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BrushRef {
    /// Entity index (0 is worldspawn).
    pub entity: usize,
    /// Brush index within the entity.
    pub brush: usize,
    /// Side index within the brush.
    pub side: Option<usize>,
}

impl std::fmt::Display for BrushRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "entity {} brush {}", self.entity, self.brush)?;
        if let Some(side) = self.side {
            write!(f, " side {side}")?;
        }
        Ok(())
    }
}

/// What went wrong while parsing a `.map`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MapErrorKind {
    /// The file holds no entity at all.
    #[error("empty map: no entities")]
    Empty,
    /// The first entity is not `worldspawn`.
    #[error("the first entity is `{0}`, expected `worldspawn`")]
    FirstNotWorldspawn(String),
    /// End of file inside an entity or brush; the location is the opening brace.
    #[error("unclosed `{{` of this {0} (end of file reached)")]
    Unclosed(&'static str),
    /// End of file where more was needed.
    #[error("unexpected end of file, expected {0}")]
    UnexpectedEof(&'static str),
    /// A token that does not belong here.
    #[error("unexpected `{found}`, expected {expected}")]
    Stray {
        /// The token found (truncated to 40 characters).
        found: String,
        /// What the grammar needed.
        expected: &'static str,
    },
    /// A quoted string without its closing quote on the same line.
    #[error("unterminated quoted string")]
    UnterminatedString,
    /// A word that should be a number.
    #[error("expected a number, found `{0}`")]
    NotANumber(String),
    /// A number that is infinite or NaN.
    #[error("non-finite number `{0}`")]
    NonFinite(String),
    /// A point coordinate beyond [`WORLD_LIMIT`].
    #[error("coordinate {0} is beyond the world limit of ±{WORLD_LIMIT}")]
    OutOfWorld(f64),
    /// The three points of a side are collinear (or coincide).
    #[error("degenerate plane: the three points are collinear")]
    DegeneratePlane,
    /// A brush with fewer than four sides cannot be closed.
    #[error("brush has {0} sides, at least 4 are needed")]
    TooFewSides(usize),
}

/// A `.map` parse error with its location; displays as `file:line:col: [entity E brush B side S: ]message`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{col}: {}{kind}", context(.brush))]
pub struct MapError {
    /// The file name given to [`parse`].
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column (characters).
    pub col: u32,
    /// The brush (and side) concerned, when the error is inside a brush.
    pub brush: Option<BrushRef>,
    /// What went wrong.
    pub kind: MapErrorKind,
}

/// The text of `.map` bytes: the bytes themselves when they are valid UTF-8, else each byte as
/// the character of the same code (Latin-1), so that decoding never fails and loses nothing (see
/// the module docs).
pub fn decode(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    match std::str::from_utf8(bytes) {
        Ok(text) => std::borrow::Cow::Borrowed(text),
        Err(_) => std::borrow::Cow::Owned(bytes.iter().map(|&b| char::from(b)).collect()),
    }
}

/// The bytes of text produced by [`decode`] from a file that is not UTF-8: each character below
/// `U+0100` as its byte; `None` when the text holds a character above `U+00FF`, which no
/// Latin-1-decoded file does.
pub fn encode_latin1(text: &str) -> Option<Vec<u8>> {
    text.chars().map(|c| u8::try_from(u32::from(c)).ok()).collect()
}

/// Parse the bytes of a `.map` file: [`decode`], then [`parse`]. `file` is only used in error
/// messages.
pub fn parse_bytes(bytes: &[u8], file: &str) -> Result<MapFile, MapError> {
    parse(&decode(bytes), file)
}

/// Parse `.map` text. `file` is only used in error messages.
///
/// Accepts Standard and Valve 220 sides (detected per side: a `[` after the texture name means
/// Valve), and extra numbers after the scales on the side's line (Quake 2 contents/flags/value,
/// ignored). [`MapFile::format`] is [`MapFormat::Valve220`] when any side is Valve or worldspawn
/// has `"mapversion" "220"`. Rejects unclosed braces, stray tokens, non-numbers, non-finite numbers,
/// point coordinates beyond [`WORLD_LIMIT`], collinear side points, brushes with fewer than four
/// sides, files without entities and a first entity other than `worldspawn`.
pub fn parse(text: &str, file: &str) -> Result<MapFile, MapError> {
    Parser { lx: Lexer::new(text), file, brush: None }.file()
}

/// `"entity E brush B side S: "` or nothing.
fn context(brush: &Option<BrushRef>) -> String {
    brush.map(|b| format!("{b}: ")).unwrap_or_default()
}

/// Truncate a token for an error message.
fn shown(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}…", &text[..i]),
        None => text.to_string(),
    }
}

struct Parser<'a, 'f> {
    lx: Lexer<'a>,
    file: &'f str,
    /// The brush being parsed, for error context.
    brush: Option<BrushRef>,
}

impl<'a> Parser<'a, '_> {
    fn err(&self, line: u32, col: u32, kind: MapErrorKind) -> MapError {
        MapError { file: self.file.to_string(), line, col, brush: self.brush, kind }
    }

    fn at(&self, tok: &Token<'_>, kind: MapErrorKind) -> MapError {
        self.err(tok.line, tok.col, kind)
    }

    fn lex_err(&self, u: Unterminated) -> MapError {
        self.err(u.line, u.col, MapErrorKind::UnterminatedString)
    }

    fn peek(&mut self) -> Result<Option<Token<'a>>, MapError> {
        self.lx.peek().map_err(|u| self.lex_err(u))
    }

    /// The next token, or an end-of-file error saying what was `expected`.
    fn next(&mut self, expected: &'static str) -> Result<Token<'a>, MapError> {
        match self.lx.next_token() {
            Ok(Some(t)) => Ok(t),
            Ok(None) => {
                let (line, col) = self.lx.end_position();
                Err(self.err(line, col, MapErrorKind::UnexpectedEof(expected)))
            }
            Err(u) => Err(self.lex_err(u)),
        }
    }

    fn stray(&self, tok: &Token<'_>, expected: &'static str) -> MapError {
        let found = if tok.quoted { format!("\"{}\"", shown(tok.text)) } else { shown(tok.text) };
        self.at(tok, MapErrorKind::Stray { found, expected })
    }

    /// Consume the bare word `word`.
    fn expect(&mut self, word: &'static str, expected: &'static str) -> Result<Token<'a>, MapError> {
        let tok = self.next(expected)?;
        if tok.quoted || tok.text != word {
            return Err(self.stray(&tok, expected));
        }
        Ok(tok)
    }

    fn number(&mut self) -> Result<f64, MapError> {
        let tok = self.next("a number")?;
        self.number_of(&tok)
    }

    fn number_of(&self, tok: &Token<'_>) -> Result<f64, MapError> {
        let Some(v) = crate::decimal::parse_f64(tok.text) else {
            return Err(self.at(tok, MapErrorKind::NotANumber(shown(tok.text))));
        };
        if !v.is_finite() {
            return Err(self.at(tok, MapErrorKind::NonFinite(shown(tok.text))));
        }
        Ok(v)
    }

    fn file(mut self) -> Result<MapFile, MapError> {
        let mut entities = Vec::new();
        while let Some(tok) = self.lx.next_token().map_err(|u| self.lex_err(u))? {
            if tok.quoted || tok.text != "{" {
                return Err(self.stray(&tok, "`{` opening an entity"));
            }
            entities.push(self.entity(&tok, entities.len())?);
        }
        let Some(world) = entities.first() else {
            let (line, col) = self.lx.end_position();
            return Err(self.err(line, col, MapErrorKind::Empty));
        };
        if world.classname() != "worldspawn" {
            return Err(self.err(world.line, 1, MapErrorKind::FirstNotWorldspawn(shown(world.classname()))));
        }
        let valve = world.get("mapversion").is_some_and(|v| v.trim() == "220")
            || entities
                .iter()
                .flat_map(|e| &e.brushes)
                .flat_map(|b| &b.sides)
                .any(|s| matches!(s.axes, TexAxes::Valve { .. }));
        let format = if valve { MapFormat::Valve220 } else { MapFormat::Standard };
        Ok(MapFile { entities, format })
    }

    /// An entity after its opening brace `open`.
    fn entity(&mut self, open: &Token<'_>, index: usize) -> Result<Entity, MapError> {
        let mut entity = Entity { properties: Vec::new(), brushes: Vec::new(), line: open.line };
        loop {
            let Some(tok) = self.lx.next_token().map_err(|u| self.lex_err(u))? else {
                return Err(self.at(open, MapErrorKind::Unclosed("entity")));
            };
            if tok.quoted {
                let value = self.next("a quoted value")?;
                if !value.quoted {
                    return Err(self.stray(&value, "a quoted value"));
                }
                entity.properties.push((tok.text.to_string(), value.text.to_string()));
            } else if tok.text == "{" {
                self.brush = Some(BrushRef { entity: index, brush: entity.brushes.len(), side: None });
                let brush = self.brush_body(&tok)?;
                self.brush = None;
                entity.brushes.push(brush);
            } else if tok.text == "}" {
                return Ok(entity);
            } else {
                return Err(self.stray(&tok, "a quoted key, `{` or `}`"));
            }
        }
    }

    /// A brush after its opening brace `open`; `self.brush` names it.
    fn brush_body(&mut self, open: &Token<'_>) -> Result<Brush, MapError> {
        let mut sides = Vec::new();
        loop {
            let Some(tok) = self.peek()? else {
                if let Some(b) = &mut self.brush {
                    b.side = None;
                }
                return Err(self.at(open, MapErrorKind::Unclosed("brush")));
            };
            if let Some(b) = &mut self.brush {
                b.side = Some(sides.len());
            }
            if !tok.quoted && tok.text == "}" {
                self.next("`}`")?;
                if sides.len() < 4 {
                    if let Some(b) = &mut self.brush {
                        b.side = None;
                    }
                    return Err(self.at(open, MapErrorKind::TooFewSides(sides.len())));
                }
                return Ok(Brush { sides, line: open.line });
            }
            sides.push(self.side()?);
        }
    }

    fn point(&mut self) -> Result<DVec3, MapError> {
        self.expect("(", "`(` opening a point")?;
        let mut p = DVec3::ZERO;
        for axis in 0..3 {
            let tok = self.next("a coordinate")?;
            let v = self.number_of(&tok)?;
            if v.abs() > WORLD_LIMIT {
                return Err(self.at(&tok, MapErrorKind::OutOfWorld(v)));
            }
            p[axis] = v;
        }
        self.expect(")", "`)` closing a point")?;
        Ok(p)
    }

    /// `[ x y z offset ]` of a Valve 220 side.
    fn valve_axis(&mut self) -> Result<[f64; 4], MapError> {
        self.expect("[", "`[` opening a texture axis")?;
        let axis = [self.number()?, self.number()?, self.number()?, self.number()?];
        self.expect("]", "`]` closing a texture axis")?;
        Ok(axis)
    }

    fn side(&mut self) -> Result<BrushSide, MapError> {
        let first = self.peek()?;
        let (line, col) = first.map_or_else(|| self.lx.end_position(), |t| (t.line, t.col));
        let points = [self.point()?, self.point()?, self.point()?];
        let tex = self.next("a texture name")?;
        if !tex.quoted && matches!(tex.text, "(" | ")" | "{" | "}" | "[" | "]") {
            return Err(self.stray(&tex, "a texture name"));
        }
        let valve = self.peek()?.is_some_and(|t| !t.quoted && t.text == "[");
        let axes = if valve {
            let u = self.valve_axis()?;
            let v = self.valve_axis()?;
            let rotation = self.number()?;
            let scale = [self.number()?, self.number()?];
            TexAxes::Valve { u, v, rotation, scale }
        } else {
            let offset = [self.number()?, self.number()?];
            let rotation = self.number()?;
            let scale = [self.number()?, self.number()?];
            TexAxes::Standard { offset, rotation, scale }
        };
        // Quake 2 style extras: further numbers on the same line.
        while let Some(tok) = self.peek()? {
            if tok.line != line || (!tok.quoted && matches!(tok.text, "(" | "}")) {
                break;
            }
            let tok = self.next("a number")?;
            self.number_of(&tok)?;
        }
        let Some(plane) = Plane::from_points(points[0], points[1], points[2]) else {
            return Err(self.err(line, col, MapErrorKind::DegeneratePlane));
        };
        Ok(BrushSide { points, plane, texture: tex.text.to_string(), axes, line })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX: &str = "{\n( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) T 0 0 0 1 1\n( 64 0 0 ) ( 64 0 1 ) ( 64 1 0 ) T 0 0 0 1 1\n\
        ( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) T 0 0 0 1 1\n( 0 64 0 ) ( 1 64 0 ) ( 0 64 1 ) T 0 0 0 1 1\n\
        ( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) T 0 0 0 1 1\n( 0 0 64 ) ( 0 1 64 ) ( 1 0 64 ) T 0 0 0 1 1\n}\n";

    fn world(body: &str) -> String {
        format!("{{\n\"classname\" \"worldspawn\"\n{body}}}\n")
    }

    fn err(text: &str) -> MapError {
        parse(text, "t.map").expect_err("should fail")
    }

    #[test]
    fn texture_vectors_follow_qbsp() {
        let std = |rotation, scale: [f64; 2]| TexAxes::Standard { offset: [8.0, -4.0], rotation, scale };
        let up = DVec3::Z;
        // A floor projects onto x and -y; offsets pass through.
        assert_eq!(std(0.0, [1.0, 1.0]).vectors(up), [[1.0, 0.0, 0.0, 8.0], [0.0, -1.0, 0.0, -4.0]]);
        // Rotating by 90 degrees swaps the axes as qbsp does; scales divide; zero scale is 1.
        assert_eq!(std(90.0, [2.0, 0.0]).vectors(up), [[0.0, 0.5, 0.0, 8.0], [1.0, 0.0, 0.0, -4.0]]);
        // A wall facing -y (north) projects onto x and -z; 45 degrees mixes them.
        let v = std(45.0, [1.0, 1.0]).vectors(-DVec3::Y);
        let h = 0.5f64.sqrt();
        assert!((v[0][0] - h).abs() < 1e-12 && (v[0][2] - h).abs() < 1e-12, "{v:?}");
        // Valve 220 gives the axes; scales divide them, offsets are kept.
        let valve = TexAxes::Valve {
            u: [0.0, 1.0, 0.0, 3.0],
            v: [0.0, 0.0, -1.0, 5.0],
            rotation: 0.0,
            scale: [0.5, 2.0],
        };
        assert_eq!(valve.vectors(up), [[0.0, 2.0, 0.0, 3.0], [0.0, 0.0, -0.5, 5.0]]);
    }

    #[test]
    fn bounds_come_from_the_brush_corners() {
        let map = parse(&world(BOX), "t.map").unwrap();
        assert_eq!(map.bounds(), Aabb::new(DVec3::ZERO, DVec3::splat(64.0)));
        assert_eq!(map.brushes().count(), 1);
        let windings = map.entities[0].brushes[0].windings();
        assert!(
            windings
                .iter()
                .all(|w| w.as_ref().is_some_and(|w| w.len() == 4 && (w.area() - 4096.0).abs() < 1e-6))
        );
    }

    #[test]
    fn standard_box_planes_face_out() {
        let text =
            world(BOX) + "// a comment\n{ \"classname\" \"info_player_start\" \"origin\" \"32 32 24\" }\n";
        let map = parse(&text, "t.map").unwrap();
        assert_eq!(map.format, MapFormat::Standard);
        assert_eq!(map.entities.len(), 2);
        assert_eq!(map.entities[1].origin(), Some(DVec3::new(32.0, 32.0, 24.0)));
        let brush = &map.entities[0].brushes[0];
        assert_eq!(brush.line, 3);
        assert_eq!(brush.sides.len(), 6);
        assert_eq!(brush.sides[0].line, 4);
        let centre = DVec3::splat(32.0);
        for side in &brush.sides {
            assert!(side.plane.distance(centre) < -31.9, "{:?} faces in", side.plane);
            assert!(side.plane.normal.abs().max_element() == 1.0);
        }
        assert_eq!(brush.sides[0].plane.normal, DVec3::NEG_X);
        assert_eq!(
            brush.sides[0].axes,
            TexAxes::Standard { offset: [0.0, 0.0], rotation: 0.0, scale: [1.0, 1.0] }
        );
    }

    #[test]
    fn valve_sides_are_detected_per_side() {
        let valve = BOX.replacen("T 0 0 0 1 1", "T [ 1 0 0 8 ] [ 0 -1 0 -4 ] 0 0.5 0.5", 1);
        let map = parse(&world(&valve), "t.map").unwrap();
        assert_eq!(map.format, MapFormat::Valve220);
        let sides = &map.entities[0].brushes[0].sides;
        assert_eq!(
            sides[0].axes,
            TexAxes::Valve {
                u: [1.0, 0.0, 0.0, 8.0],
                v: [0.0, -1.0, 0.0, -4.0],
                rotation: 0.0,
                scale: [0.5, 0.5]
            }
        );
        assert!(matches!(sides[1].axes, TexAxes::Standard { .. }));
    }

    #[test]
    fn mapversion_220_marks_valve() {
        let text = "{\n\"classname\" \"worldspawn\"\n\"mapversion\" \"220\"\n}\n";
        assert_eq!(parse(text, "t.map").unwrap().format, MapFormat::Valve220);
    }

    #[test]
    fn quake2_extras_and_quoted_textures_are_accepted() {
        let q2 = BOX.replace("T 0 0 0 1 1", "\"e1u1/floor\" 0 0 0 1 1 0 0 0");
        let map = parse(&world(&q2), "t.map").unwrap();
        assert_eq!(map.entities[0].brushes[0].sides.len(), 6);
        assert_eq!(map.entities[0].brushes[0].sides[0].texture, "e1u1/floor");
    }

    #[test]
    fn fence_texture_names_may_start_with_a_brace() {
        let map = parse(&world(&BOX.replace(" T ", " {fence ")), "t.map").unwrap();
        assert_eq!(map.entities[0].brushes[0].sides[3].texture, "{fence");
    }

    #[test]
    fn empty_file_is_rejected() {
        assert_eq!(err("").kind, MapErrorKind::Empty);
        assert_eq!(err("// only a comment\n\n").kind, MapErrorKind::Empty);
    }

    #[test]
    fn first_entity_must_be_worldspawn() {
        let e = err("{ \"classname\" \"light\" }\n");
        assert_eq!(e.kind, MapErrorKind::FirstNotWorldspawn("light".into()));
        assert_eq!(e.to_string(), "t.map:1:1: the first entity is `light`, expected `worldspawn`");
    }

    #[test]
    fn unclosed_entity_and_brush_name_the_brace() {
        let e = err("{\n\"classname\" \"worldspawn\"\n");
        assert_eq!((e.kind, e.line, e.col), (MapErrorKind::Unclosed("entity"), 1, 1));
        let text = world(BOX);
        let cut = &text[..text.rfind("}\n}").unwrap()];
        let e = err(cut);
        assert_eq!((e.kind.clone(), e.line, e.col), (MapErrorKind::Unclosed("brush"), 3, 1));
        assert_eq!(e.brush, Some(BrushRef { entity: 0, brush: 0, side: None }));
        // Cut inside a side: end of file while a number was expected, with the side named.
        let e = err(&text[..text.find("T 0 0 0 1 1").unwrap()]);
        assert_eq!(e.kind, MapErrorKind::UnexpectedEof("a texture name"));
        assert_eq!(e.brush, Some(BrushRef { entity: 0, brush: 0, side: Some(0) }));
    }

    #[test]
    fn stray_tokens_are_rejected_with_position() {
        let e = err("x { }");
        assert_eq!(e.kind, MapErrorKind::Stray { found: "x".into(), expected: "`{` opening an entity" });
        assert_eq!((e.line, e.col), (1, 1));
        let e = err("{\n\"classname\" \"worldspawn\"\n  bogus\n}");
        assert_eq!((e.line, e.col), (3, 3));
        assert!(matches!(e.kind, MapErrorKind::Stray { .. }));
        // A value must be quoted.
        assert!(matches!(err("{ \"classname\" worldspawn }").kind, MapErrorKind::Stray { .. }));
        // A word after the scales on the same line.
        let e = err(&world(&BOX.replacen("T 0 0 0 1 1", "T 0 0 0 1 1 junk", 1)));
        assert_eq!(e.kind, MapErrorKind::NotANumber("junk".into()));
        assert_eq!((e.line, e.col), (4, 43));
        // A missing `)`.
        let e = err(&world(&BOX.replacen("( 0 1 0 )", "( 0 1 0 0 )", 1)));
        assert!(matches!(e.kind, MapErrorKind::Stray { .. }));
        assert_eq!(e.brush, Some(BrushRef { entity: 0, brush: 0, side: Some(0) }));
    }

    #[test]
    fn non_numbers_and_non_finite_numbers_are_rejected() {
        let e = err(&world(&BOX.replacen("( 64 0 0 )", "( 64 zero 0 )", 1)));
        assert_eq!(e.kind, MapErrorKind::NotANumber("zero".into()));
        assert_eq!((e.line, e.col, e.brush.and_then(|b| b.side)), (5, 6, Some(1)));
        let e = err(&world(&BOX.replacen("( 64 0 0 )", "( 64 NaN 0 )", 1)));
        assert_eq!(e.kind, MapErrorKind::NonFinite("NaN".into()));
        let e = err(&world(&BOX.replacen("T 0 0 0 1 1", "T 0 0 0 inf 1", 1)));
        assert_eq!(e.kind, MapErrorKind::NonFinite("inf".into()));
    }

    #[test]
    fn coordinates_beyond_the_world_are_rejected() {
        let e = err(&world(&BOX.replacen("( 64 0 0 )", "( 1000001 0 0 )", 1)));
        assert_eq!(e.kind, MapErrorKind::OutOfWorld(1_000_001.0));
        // Exactly the limit is allowed.
        assert!(parse(&world(&BOX.replace("64", "1000000")), "t.map").is_ok());
    }

    #[test]
    fn collinear_points_name_entity_brush_and_side_line() {
        let body = format!(
            "{BOX}{}",
            BOX.replacen("( 64 0 0 ) ( 64 0 1 ) ( 64 1 0 )", "( 64 0 0 ) ( 64 0 1 ) ( 64 0 2 )", 1)
        );
        let e = err(&world(&body));
        assert_eq!(e.kind, MapErrorKind::DegeneratePlane);
        assert_eq!(e.brush, Some(BrushRef { entity: 0, brush: 1, side: Some(1) }));
        assert_eq!((e.line, e.col), (13, 1));
        assert_eq!(
            e.to_string(),
            "t.map:13:1: entity 0 brush 1 side 1: degenerate plane: the three points are collinear"
        );
    }

    #[test]
    fn brushes_need_four_sides() {
        let three: String = BOX.lines().take(4).chain(["}"]).map(|l| format!("{l}\n")).collect();
        let e = err(&world(&three));
        assert_eq!(e.kind, MapErrorKind::TooFewSides(3));
        assert_eq!(e.brush, Some(BrushRef { entity: 0, brush: 0, side: None }));
        assert_eq!(e.line, 3);
    }

    #[test]
    fn unterminated_strings_are_rejected() {
        let e = err("{\n\"classname\" \"worldspawn\n}\n");
        assert_eq!((e.kind, e.line, e.col), (MapErrorKind::UnterminatedString, 2, 13));
    }

    #[test]
    fn high_bit_bytes_in_strings_are_kept_as_latin1_characters() {
        // Quake's "gold" characters: bytes 0x80..=0xFF inside a quoted value (not UTF-8).
        let mut bytes = b"{\n\"classname\" \"worldspawn\"\n\"message\" \"".to_vec();
        let gold: Vec<u8> = (0x80..=0xFFu8).collect();
        bytes.extend_from_slice(&gold);
        bytes.extend_from_slice(b"\"\n");
        bytes.extend_from_slice(BOX.as_bytes());
        bytes.extend_from_slice(b"}\n");
        assert!(std::str::from_utf8(&bytes).is_err());
        let map = parse_bytes(&bytes, "gold.map").expect("high-bit bytes are accepted");
        let message = map.entities[0].get("message").expect("message key");
        assert_eq!(message.chars().count(), 128);
        assert_eq!(encode_latin1(message), Some(gold));
        assert_eq!(map.entities[0].brushes[0].sides.len(), 6);
        // Valid UTF-8 is read as UTF-8, unchanged.
        let utf8 = world(BOX).replace("worldspawn\"", "worldspawn\"\n\"message\" \"caf\u{e9}\"");
        assert!(matches!(decode(utf8.as_bytes()), std::borrow::Cow::Borrowed(_)));
        let map = parse_bytes(utf8.as_bytes(), "utf8.map").expect("UTF-8 map");
        assert_eq!(map.entities[0].get("message"), Some("caf\u{e9}"));
        // Errors after high-bit bytes still name the line and the column in characters.
        let bad = b"{\n\"classname\" \"worldspawn\"\n\"message\" \"\xe9\xe9\" oops\n}\n";
        let e = parse_bytes(bad, "bad.map").expect_err("stray word");
        assert_eq!((e.line, e.col), (3, 16));
    }

    #[test]
    fn every_truncation_of_a_valid_map_is_handled() {
        let text = world(BOX) + "{ \"classname\" \"info_player_start\" \"origin\" \"32 32 24\" }\n";
        let world_end = world(BOX).len() - 1;
        let ok: Vec<usize> = (0..text.len()).filter(|&cut| parse(&text[..cut], "t.map").is_ok()).collect();
        // Only cuts right after a complete entity (before or after its newline) succeed.
        assert_eq!(ok, [world_end, world_end + 1, text.len() - 1]);
    }

    mod hostile {
        use proptest::prelude::*;

        use super::super::*;
        use super::{BOX, world};

        proptest! {
            #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

            /// Byte edits of a valid map parse or fail with a located error; never panic.
            #[test]
            fn mutated_text_never_panics(
                edits in proptest::collection::vec((0usize..4096, prop_oneof![
                    Just(b'{'), Just(b'}'), Just(b'('), Just(b')'), Just(b'['), Just(b']'), Just(b'"'),
                    Just(b'/'), Just(b'\n'), Just(b' '), Just(b'-'), Just(b'9'), Just(b'e'), any::<u8>()
                ], 0u8..3), 1..8)
            ) {
                let text = world(BOX);
                let mut bytes = text.into_bytes();
                crate::test_support::apply_edits(&mut bytes, &edits);
                let text = decode(&bytes);
                match parse(&text, "h.map") {
                    Ok(map) => {
                        prop_assert_eq!(map.entities[0].classname(), "worldspawn");
                        for side in map.entities.iter().flat_map(|e| &e.brushes).flat_map(|b| &b.sides) {
                            prop_assert!(side.plane.normal.is_finite() && side.plane.dist.is_finite());
                        }
                    }
                    Err(e) => {
                        let lines = text.lines().count() as u32 + 1;
                        prop_assert!(e.line >= 1 && e.line <= lines, "{}", e);
                        prop_assert!(e.col >= 1);
                    }
                }
            }
        }
    }
}
