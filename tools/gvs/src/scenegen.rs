//! The generated benchmark scenes of `sightline gvs gen:<city|spheres|mixed|mesh>:<size>` (a
//! feature of the shipped command, also used by the tests and benchmarks): procedural triangle
//! scenes of the kinds the GVS thesis measures, a maze city of box buildings, random spheres
//! (optionally half replaced by single triangles) in a 40³ box, and a flat mesh.
//!
//! # Conventions
//! - `z` is up; units are arbitrary world units (a city block is [`BLOCK`] units wide).
//! - Every generator is deterministic for a given size and seed.
//! - Each scene also suggests view cells ([`Scene::cells`]): boxes in open space where a viewer
//!   could stand (five street blocks of the city spread over it, the empty middle of the sphere
//!   box and four more empty boxes, a slab above the mesh). `sightline gvs --cell auto` uses
//!   them.

use glam::Vec3;

/// Width of one city block (street or building) in world units.
pub const BLOCK: f32 = 10.0;
/// Height of one building floor (facade tessellation).
const FLOOR: f32 = 3.0;
/// Width of one facade column (facade tessellation).
const COLUMN: f32 = 2.5;
/// Side of the sphere scene's box.
pub const SPHERE_BOX: f32 = 40.0;

/// A generated triangle scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The triangles.
    pub triangles: Vec<[Vec3; 3]>,
    /// Suggested view cells as `(min, max)` boxes in open space.
    pub cells: Vec<(Vec3, Vec3)>,
    /// Where a camera can stand, as `(min, max)` boxes: the city's streets at eye height
    /// ([`EYE_HEIGHT`] give or take a quarter unit), the whole sphere box (a point inside a sphere
    /// is not open; the boxes do not say so), a slab above the mesh.
    pub open: Vec<(Vec3, Vec3)>,
}

/// Eye height above a city street.
pub const EYE_HEIGHT: f32 = 1.75;

/// Which generator, parsed from `gen:<kind>:<size>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A maze city of `size × size` blocks.
    City,
    /// `size` tessellated spheres in a 40³ box.
    Spheres,
    /// `size` objects in a 40³ box, half spheres and half single triangles.
    Mixed,
    /// A flat triangulated square of about `size` triangles.
    Mesh,
}

/// Errors of [`parse_spec`].
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum SpecError {
    /// Not of the form `gen:<kind>:<size>`.
    #[error("scene spec `{0}` is not gen:<city|spheres|mixed|mesh>:<size>")]
    Form(String),
    /// Size out of range.
    #[error("scene size {size} out of range 1..={max} for `{kind}`")]
    Size {
        /// The kind's name.
        kind: String,
        /// Given size.
        size: u64,
        /// Largest accepted.
        max: u64,
    },
}

/// Parse `gen:<kind>:<size>`; returns `None` when `spec` does not start with `gen:`.
pub fn parse_spec(spec: &str) -> Option<Result<(Kind, u32), SpecError>> {
    let rest = spec.strip_prefix("gen:")?;
    let form = || SpecError::Form(spec.to_string());
    let Some((kind, size)) = rest.split_once(':') else {
        return Some(Err(form()));
    };
    let (kind, max) = match kind {
        "city" => (Kind::City, 400),
        "spheres" => (Kind::Spheres, 200_000),
        "mixed" => (Kind::Mixed, 200_000),
        "mesh" => (Kind::Mesh, 20_000_000),
        _ => return Some(Err(form())),
    };
    let Ok(size) = size.parse::<u64>() else {
        return Some(Err(form()));
    };
    if size == 0 || size > max {
        let name = rest.split(':').next().unwrap_or_default().to_string();
        return Some(Err(SpecError::Size { kind: name, size, max }));
    }
    Some(Ok((kind, size as u32)))
}

/// Generate a scene of `kind` and `size` (see [`Kind`]) from `seed`.
pub fn generate(kind: Kind, size: u32, seed: u64) -> Scene {
    match kind {
        Kind::City => city(size as usize, seed),
        Kind::Spheres => spheres(size as usize, false, seed),
        Kind::Mixed => spheres(size as usize, true, seed),
        Kind::Mesh => mesh(size as usize),
    }
}

/// The generators' random stream: the project's SplitMix64.
pub use sightline_job::rng::SplitMix64 as Rng;

/// Push the two triangles of the quad `a b c d` (in order around it).
fn quad(out: &mut Vec<[Vec3; 3]>, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    out.push([a, b, c]);
    out.push([a, c, d]);
}

/// Push a quad split into `nu × nv` quads: corner `o`, edges `u` and `v`.
fn grid(out: &mut Vec<[Vec3; 3]>, o: Vec3, u: Vec3, v: Vec3, nu: usize, nv: usize) {
    let (nu, nv) = (nu.max(1), nv.max(1));
    for i in 0..nu {
        for j in 0..nv {
            let p = |a: usize, b: usize| o + u * (a as f32 / nu as f32) + v * (b as f32 / nv as f32);
            quad(out, p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
        }
    }
}

/// The maze: `true` marks a building block. Streets form a perfect maze on the odd cells, opened
/// with extra crossings so that long views down streets exist, as in a real city.
fn maze(n: usize, rng: &mut Rng) -> Vec<bool> {
    let mut solid = vec![true; n * n];
    let cells_per_side = n.saturating_sub(1) / 2;
    if cells_per_side == 0 {
        return vec![false; n * n];
    }
    let at = |i: usize, j: usize| j * n + i;
    let mut seen = vec![false; cells_per_side * cells_per_side];
    let mut stack = vec![(0usize, 0usize)];
    seen[0] = true;
    solid[at(1, 1)] = false;
    while let Some(&(ci, cj)) = stack.last() {
        let mut next = Vec::with_capacity(4);
        if ci > 0 && !seen[cj * cells_per_side + ci - 1] {
            next.push((ci - 1, cj));
        }
        if ci + 1 < cells_per_side && !seen[cj * cells_per_side + ci + 1] {
            next.push((ci + 1, cj));
        }
        if cj > 0 && !seen[(cj - 1) * cells_per_side + ci] {
            next.push((ci, cj - 1));
        }
        if cj + 1 < cells_per_side && !seen[(cj + 1) * cells_per_side + ci] {
            next.push((ci, cj + 1));
        }
        if next.is_empty() {
            stack.pop();
            continue;
        }
        let (ni, nj) = next[rng.below(next.len())];
        seen[nj * cells_per_side + ni] = true;
        solid[at(2 * ni + 1, 2 * nj + 1)] = false;
        solid[at(ci + ni + 1, cj + nj + 1)] = false;
        stack.push((ni, nj));
    }
    // Open a quarter of the remaining walls between two streets.
    for j in 1..n - 1 {
        for i in 1..n - 1 {
            let horizontal = !solid[at(i - 1, j)] && !solid[at(i + 1, j)];
            let vertical = !solid[at(i, j - 1)] && !solid[at(i, j + 1)];
            if solid[at(i, j)] && (i + j) % 2 == 1 && (horizontal || vertical) && rng.below(4) == 0 {
                solid[at(i, j)] = false;
            }
        }
    }
    solid
}

/// A maze city of `n × n` blocks, each [`BLOCK`] wide. Buildings are boxes 8–40 units tall with
/// facades tessellated in floors and columns (only where not hidden by a taller neighbour); streets
/// are tessellated ground quads. About 130 triangles per block: `n = 100` gives about 1.3 M.
pub fn city(n: usize, seed: u64) -> Scene {
    let n = n.max(3);
    let mut rng = Rng::new(seed ^ 0x9E37_79B9_7F4A_7C15);
    let solid = maze(n, &mut rng);
    let heights: Vec<f32> =
        solid.iter().map(|&s| if s { (rng.range(8.0, 40.0) / FLOOR).round() * FLOOR } else { 0.0 }).collect();
    let h = |i: isize, j: isize| -> f32 {
        if i < 0 || j < 0 || i >= n as isize || j >= n as isize {
            0.0
        } else {
            heights[j as usize * n + i as usize]
        }
    };
    let mut tris = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let o = Vec3::new(i as f32 * BLOCK, j as f32 * BLOCK, 0.0);
            let top = h(i as isize, j as isize);
            if top == 0.0 {
                grid(&mut tris, o, Vec3::X * BLOCK, Vec3::Y * BLOCK, 2, 2);
                continue;
            }
            let z = Vec3::Z * top;
            quad(
                &mut tris,
                o + z,
                o + z + Vec3::X * BLOCK,
                o + z + Vec3::new(BLOCK, BLOCK, 0.0),
                o + z + Vec3::Y * BLOCK,
            );
            let cols = (BLOCK / COLUMN).round() as usize;
            // Facades: (neighbour offset, corner, along-edge vector), outward normal to the right.
            let sides = [
                ((0, -1), o, Vec3::X * BLOCK),
                ((1, 0), o + Vec3::X * BLOCK, Vec3::Y * BLOCK),
                ((0, 1), o + Vec3::new(BLOCK, BLOCK, 0.0), -Vec3::X * BLOCK),
                ((-1, 0), o + Vec3::Y * BLOCK, -Vec3::Y * BLOCK),
            ];
            for ((di, dj), corner, along) in sides {
                let base = h(i as isize + di, j as isize + dj);
                if base >= top {
                    continue;
                }
                let floors = ((top - base) / FLOOR).round().max(1.0) as usize;
                grid(&mut tris, corner + Vec3::Z * base, along, Vec3::Z * (top - base), cols, floors);
            }
        }
    }
    // Suggested cells: the street blocks nearest the centre and nearest the centres of the four
    // quadrants, at eye height.
    let mut cells: Vec<(Vec3, Vec3)> = Vec::new();
    let targets =
        [(n / 2, n / 2), (n / 4, n / 4), (3 * n / 4, n / 4), (n / 4, 3 * n / 4), (3 * n / 4, 3 * n / 4)];
    for (ti, tj) in targets {
        let mut best: Option<(usize, usize, usize)> = None;
        for j in 0..n {
            for i in 0..n {
                if !solid[j * n + i] {
                    let d = i.abs_diff(ti) + j.abs_diff(tj);
                    if best.is_none_or(|(bd, _, _)| d < bd) {
                        best = Some((d, i, j));
                    }
                }
            }
        }
        if let Some((_, i, j)) = best {
            let o = Vec3::new(i as f32 * BLOCK, j as f32 * BLOCK, 0.0);
            let cell = (o + Vec3::new(3.0, 3.0, 1.0), o + Vec3::new(7.0, 7.0, 3.0));
            if !cells.contains(&cell) {
                cells.push(cell);
            }
        }
    }
    let open = (0..n * n)
        .filter(|&b| !solid[b])
        .map(|b| {
            let o = Vec3::new((b % n) as f32 * BLOCK, (b / n) as f32 * BLOCK, EYE_HEIGHT);
            (o + Vec3::new(1.0, 1.0, -0.25), o + Vec3::new(BLOCK - 1.0, BLOCK - 1.0, 0.25))
        })
        .collect();
    Scene { triangles: tris, cells, open }
}

/// Push a UV sphere: `stacks × slices` quads (triangles at the poles), 80 triangles, wound
/// counter-clockwise seen from outside. Closed: the seam's and the poles' vertices are computed
/// once, so every edge is shared, bit for bit, by exactly two triangles (in `f32`, `sin(π)` and
/// `sin(2π)` are not 0, and computing them per slice left cracks a ray could slip through).
fn sphere(out: &mut Vec<[Vec3; 3]>, c: Vec3, r: f32) {
    const STACKS: usize = 6;
    const SLICES: usize = 8;
    let p = |st: usize, sl: usize| {
        if st == 0 || st == STACKS {
            return c + Vec3::new(0.0, 0.0, if st == 0 { r } else { -r });
        }
        let theta = std::f32::consts::PI * st as f32 / STACKS as f32;
        let phi = std::f32::consts::TAU * (sl % SLICES) as f32 / SLICES as f32;
        c + r * Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    };
    for st in 0..STACKS {
        for sl in 0..SLICES {
            let (a, b, cc, d) = (p(st, sl), p(st + 1, sl), p(st + 1, sl + 1), p(st, sl + 1));
            if st == 0 {
                out.push([a, b, cc]);
            } else if st == STACKS - 1 {
                out.push([a, b, d]);
            } else {
                quad(out, a, b, cc, d);
            }
        }
    }
}

/// `n` objects with random centres in a [`SPHERE_BOX`]³ box: tessellated spheres of radius
/// 0.3–0.9 (80 triangles each), or with `mixed` every second one a single random triangle of
/// similar size. 4³ boxes are kept free around the suggested view cells (2³): the middle of the
/// box first, then four more around it.
pub fn spheres(n: usize, mixed: bool, seed: u64) -> Scene {
    let mut rng = Rng::new(seed ^ 0x9E37_79B9_7F4A_7C15);
    let mut tris = Vec::with_capacity(n * 80);
    let mid = Vec3::splat(SPHERE_BOX / 2.0);
    let centres = [
        mid,
        mid + Vec3::new(-10.0, -10.0, -10.0),
        mid + Vec3::new(10.0, 10.0, 10.0),
        mid + Vec3::new(10.0, -10.0, 0.0),
        mid + Vec3::new(-10.0, 10.0, 0.0),
    ];
    let mut k = 0;
    while k < n {
        let c = Vec3::new(rng.range(0.0, SPHERE_BOX), rng.range(0.0, SPHERE_BOX), rng.range(0.0, SPHERE_BOX));
        let r = rng.range(0.3, 0.9);
        if centres.iter().any(|&m| (c - m).abs().max_element() < 2.0 + r) {
            continue;
        }
        if mixed && k % 2 == 1 {
            let mut corner = || c + Vec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r)) * 1.5;
            tris.push([corner(), corner(), corner()]);
        } else {
            sphere(&mut tris, c, r);
        }
        k += 1;
    }
    Scene {
        triangles: tris,
        cells: centres.iter().map(|&m| (m - Vec3::ONE, m + Vec3::ONE)).collect(),
        open: vec![(Vec3::ZERO, Vec3::splat(SPHERE_BOX))],
    }
}

/// A flat square grid of at least `n` triangles at `z = 0`, 100 units wide; the suggested cell is a
/// box above its middle.
pub fn mesh(n: usize) -> Scene {
    let side = ((n as f64 / 2.0).sqrt().ceil() as usize).max(1);
    let mut tris = Vec::with_capacity(2 * side * side);
    grid(&mut tris, Vec3::ZERO, Vec3::X * 100.0, Vec3::Y * 100.0, side, side);
    Scene {
        triangles: tris,
        cells: vec![(Vec3::new(45.0, 45.0, 10.0), Vec3::new(55.0, 55.0, 12.0))],
        open: vec![(Vec3::new(0.0, 0.0, 1.0), Vec3::new(100.0, 100.0, 5.0))],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_reject() {
        assert_eq!(parse_spec("gen:city:10"), Some(Ok((Kind::City, 10))));
        assert_eq!(parse_spec("scene.obj"), None);
        assert!(matches!(parse_spec("gen:city"), Some(Err(SpecError::Form(_)))));
        assert!(matches!(parse_spec("gen:city:0"), Some(Err(SpecError::Size { .. }))));
        assert!(matches!(parse_spec("gen:city:99999"), Some(Err(SpecError::Size { .. }))));
        assert!(matches!(parse_spec("gen:cube:3"), Some(Err(SpecError::Form(_)))));
    }

    #[test]
    fn generators_are_deterministic_and_sized() {
        let a = city(12, 7);
        let b = city(12, 7);
        assert_eq!(a.triangles, b.triangles);
        assert!(a.triangles.len() > 12 * 12 * 8);
        assert!(!a.cells.is_empty());
        let s = spheres(50, false, 1);
        assert_eq!(s.triangles.len(), 50 * 80);
        let m = spheres(50, true, 1);
        assert_eq!(m.triangles.len(), 25 * 80 + 25);
        assert!(mesh(20_000).triangles.len() >= 20_000);
    }

    #[test]
    fn spheres_are_closed_and_wound_outwards() {
        let s = spheres(20, false, 4);
        for (k, ball) in s.triangles.chunks(80).enumerate() {
            // Every directed edge once, and its reverse once: closed, consistently wound.
            let key = |p: Vec3| p.to_array().map(f32::to_bits);
            let mut edges: Vec<_> =
                ball.iter().flat_map(|t| (0..3).map(move |i| (key(t[i]), key(t[(i + 1) % 3])))).collect();
            edges.sort_unstable();
            assert!(edges.windows(2).all(|w| w[0] != w[1]), "sphere {k}: an edge twice");
            for &(a, b) in &edges {
                assert!(edges.binary_search(&(b, a)).is_ok(), "sphere {k}: an open edge");
            }
            // Outwards: positive signed volume.
            let vol: f64 = ball
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|p| p.as_dvec3());
                    a.dot(b.cross(c))
                })
                .sum();
            assert!(vol > 0.0, "sphere {k} wound inwards");
        }
    }

    #[test]
    fn suggested_cells_and_city_streets_are_empty_of_geometry() {
        for (k, scene) in [city(15, 3), spheres(300, true, 2)].into_iter().enumerate() {
            assert!(scene.cells.len() > 1);
            // The city's streets too (the sphere box is open only outside its spheres).
            let open: &[(Vec3, Vec3)] = if k == 0 { &scene.open } else { &[] };
            assert!(k > 0 || open.len() > 15, "a street per maze cell at least");
            for t in &scene.triangles {
                for &(lo, hi) in scene.cells.iter().chain(open) {
                    let tmin = t[0].min(t[1]).min(t[2]);
                    let tmax = t[0].max(t[1]).max(t[2]);
                    let overlap = tmin.cmplt(hi).all() && tmax.cmpgt(lo).all();
                    assert!(!overlap, "triangle {t:?} overlaps cell {lo:?}..{hi:?}");
                }
            }
        }
    }
}
