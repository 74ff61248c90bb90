//! A generator of sealed Quake `.map` text of growing size, for tests and benchmarks.
//!
//! The level is a grid of `rooms_x × rooms_y` cells on each of `storeys` floors. Every cell holds
//! one room of random size; neighbouring rooms on a floor are joined by corridors along a random
//! spanning tree plus some extra loops, and floors are joined by stairwells (a shaft through the
//! ceiling below and the floor above with 16-unit steps). Some rooms get floor-to-ceiling pillars.
//!
//! # Construction and why it is sealed
//! Every open volume (room, corridor, stairwell) is an axis-aligned *air box*. Around each air box
//! go six 16-unit slabs that together cover its whole 16-unit neighbourhood; then every air box is
//! carved out of every slab (box minus box, at most six boxes). The remaining slabs cover every
//! point within 16 units of the air that is not air itself, so no path leads from the air to the
//! void: the map is sealed by construction. Pillars and steps are added after carving.
//!
//! All coordinates are integers and multiples of 16, so a test can probe the map at points
//! `16k + 8` without ever landing on a brush face. Output is deterministic for a given
//! [`MapGenParams`] (its own SplitMix64 generator, fixed iteration order).

use sightline_job::rng::SplitMix64;

use std::fmt::Write as _;

/// Wall, floor and ceiling thickness.
pub const WALL: i64 = 16;
/// Horizontal distance between cell origins.
pub const CELL: i64 = 512;
/// Vertical distance between floors.
pub const STOREY: i64 = 256;
/// Largest `rooms_x` and `rooms_y` (keeps coordinates far inside the world limit).
pub const MAX_ROOMS_PER_AXIS: u32 = 256;
/// Largest `storeys`.
pub const MAX_STOREYS: u32 = 32;

const CORRIDOR_WIDTH: i64 = 64;
const CORRIDOR_HEIGHT: i64 = 96;
const STAIR_STEP: i64 = 16;
const STAIR_WIDTH: i64 = 64;
/// Every room covers at least `[MARGIN, CELL - MARGIN]` of its cell on both axes.
const MARGIN: i64 = 96;

/// What to generate. Counts are clamped to `1..=`[`MAX_ROOMS_PER_AXIS`] and `1..=`[`MAX_STOREYS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MapGenParams {
    /// Rooms along x per floor.
    pub rooms_x: u32,
    /// Rooms along y per floor.
    pub rooms_y: u32,
    /// Floors.
    pub storeys: u32,
    /// Random seed: the same parameters always give the same text.
    pub seed: u64,
}

/// An integer axis-aligned box `[lo, hi)` in map units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IBox {
    /// Smallest corner.
    pub lo: [i64; 3],
    /// Largest corner.
    pub hi: [i64; 3],
}

impl IBox {
    pub(crate) fn new(lo: [i64; 3], hi: [i64; 3]) -> Self {
        Self { lo, hi }
    }

    fn overlaps(&self, o: &IBox) -> bool {
        (0..3).all(|i| self.lo[i] < o.hi[i] && o.lo[i] < self.hi[i])
    }

    /// The parts of `self` outside `cut`, as at most six boxes.
    fn minus(&self, cut: &IBox, out: &mut Vec<IBox>) {
        if !self.overlaps(cut) {
            out.push(*self);
            return;
        }
        let mut rest = *self;
        for axis in 0..3 {
            if cut.lo[axis] > rest.lo[axis] {
                let mut piece = rest;
                piece.hi[axis] = cut.lo[axis];
                out.push(piece);
                rest.lo[axis] = cut.lo[axis];
            }
            if cut.hi[axis] < rest.hi[axis] {
                let mut piece = rest;
                piece.lo[axis] = cut.hi[axis];
                out.push(piece);
                rest.hi[axis] = cut.hi[axis];
            }
        }
    }

    /// The six slabs covering the `t`-thick neighbourhood of `self`.
    pub(crate) fn shell(&self, t: i64) -> [IBox; 6] {
        let ([x0, y0, z0], [x1, y1, z1]) = (self.lo, self.hi);
        [
            IBox::new([x0 - t, y0 - t, z0 - t], [x1 + t, y1 + t, z0]),
            IBox::new([x0 - t, y0 - t, z1], [x1 + t, y1 + t, z1 + t]),
            IBox::new([x0 - t, y0 - t, z0], [x0, y1 + t, z1]),
            IBox::new([x1, y0 - t, z0], [x1 + t, y1 + t, z1]),
            IBox::new([x0, y0 - t, z0], [x1, y0, z1]),
            IBox::new([x0, y1, z0], [x1, y1 + t, z1]),
        ]
    }
}

/// What [`layout`] decided, for tests that check the generated text against it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Room air boxes, index `(storey * rooms_y + y) * rooms_x + x`.
    pub rooms: Vec<IBox>,
    /// Corridor and stairwell air boxes.
    pub passages: Vec<IBox>,
    /// Solid brushes: the carved walls, then pillars and steps.
    pub brushes: Vec<IBox>,
    /// Where the `info_player_start` stands.
    pub player_start: [i64; 3],
}

/// The layout's random choices, on the project's one generator.
#[derive(Debug)]
struct Rng(SplitMix64);

impl Rng {
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: u64) -> u64 {
        self.0.below(n.max(1) as usize) as u64
    }

    /// A multiple of `step` in `lo..=hi`.
    fn step(&mut self, lo: i64, hi: i64, step: i64) -> i64 {
        lo + self.below(((hi - lo) / step + 1) as u64) as i64 * step
    }

    fn chance(&mut self, percent: u64) -> bool {
        self.below(100) < percent
    }
}

/// Union-find over cells, for the spanning tree.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Decide rooms, passages and brushes.
pub fn layout(params: &MapGenParams) -> Layout {
    let nx = params.rooms_x.clamp(1, MAX_ROOMS_PER_AXIS) as usize;
    let ny = params.rooms_y.clamp(1, MAX_ROOMS_PER_AXIS) as usize;
    let ns = params.storeys.clamp(1, MAX_STOREYS) as usize;
    let mut rng = Rng(SplitMix64::new(params.seed ^ 0x5167_6874_6c69_6e65));
    let index = |x: usize, y: usize, s: usize| (s * ny + y) * nx + x;

    // Rooms: random extents within each cell, always covering [MARGIN, CELL - MARGIN].
    let mut rooms = Vec::with_capacity(nx * ny * ns);
    for s in 0..ns {
        for y in 0..ny {
            for x in 0..nx {
                let (cx, cy, z) = (x as i64 * CELL, y as i64 * CELL, s as i64 * STOREY);
                let lo = [cx + rng.step(WALL * 2, MARGIN, 16), cy + rng.step(WALL * 2, MARGIN, 16), z];
                let hi = [
                    cx + CELL - rng.step(WALL * 2, MARGIN, 16),
                    cy + CELL - rng.step(WALL * 2, MARGIN, 16),
                    z + rng.step(128, 192, 32),
                ];
                rooms.push(IBox::new(lo, hi));
            }
        }
    }

    // Corridors: a random spanning tree of each floor's grid, plus about 25% of the other edges.
    let mut passages = Vec::new();
    for s in 0..ns {
        let mut edges: Vec<(usize, usize, bool)> = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                if x + 1 < nx {
                    edges.push((index(x, y, s), index(x + 1, y, s), true));
                }
                if y + 1 < ny {
                    edges.push((index(x, y, s), index(x, y + 1, s), false));
                }
            }
        }
        for i in (1..edges.len()).rev() {
            edges.swap(i, rng.below(i as u64 + 1) as usize);
        }
        let mut parent: Vec<usize> = (0..rooms.len()).collect();
        for (a, b, along_x) in edges {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            let joins = ra != rb;
            if joins {
                parent[ra] = rb;
            }
            if joins || rng.chance(25) {
                passages.push(corridor(&rooms[a], &rooms[b], along_x, &mut rng));
            }
        }
    }

    // Stairwells: one or two per pair of floors, in random cells.
    let mut steps = Vec::new();
    let mut stair_cells = Vec::new();
    for s in 0..ns.saturating_sub(1) {
        let count = 1 + usize::from(nx * ny > 4 && rng.chance(50));
        for _ in 0..count {
            let (x, y) = (rng.below(nx as u64) as usize, rng.below(ny as u64) as usize);
            if stair_cells.contains(&(x, y, s)) {
                continue;
            }
            stair_cells.push((x, y, s));
            let (sx, sy, z) = (x as i64 * CELL + 128, y as i64 * CELL + 128, s as i64 * STOREY);
            let run = STOREY / STAIR_STEP * STAIR_STEP;
            passages.push(IBox::new([sx, sy, z], [sx + run, sy + STAIR_WIDTH, z + STOREY + WALL]));
            for i in 0..STOREY / STAIR_STEP {
                steps.push(IBox::new(
                    [sx + i * STAIR_STEP, sy, z],
                    [sx + (i + 1) * STAIR_STEP, sy + STAIR_WIDTH, z + (i + 1) * STAIR_STEP],
                ));
            }
        }
    }

    // Walls: shells around every air box, with every air box carved out.
    let airs: Vec<IBox> = rooms.iter().chain(&passages).copied().collect();
    let mut brushes = carve(&airs);

    // Pillars in about a third of the rooms not touched by a stairwell.
    for (i, room) in rooms.iter().enumerate() {
        let (x, y, s) = (i % nx, (i / nx) % ny, i / (nx * ny));
        let near_stairs =
            stair_cells.iter().any(|&(sx, sy, ss)| sx == x && sy == y && (ss == s || ss + 1 == s));
        if near_stairs || !rng.chance(35) {
            continue;
        }
        let w = room.hi[0] - room.lo[0];
        let d = room.hi[1] - room.lo[1];
        for (fx, fy) in [(1, 1), (3, 1), (1, 3), (3, 3)] {
            let px = room.lo[0] + (w * fx / 4) / 16 * 16 - 16;
            let py = room.lo[1] + (d * fy / 4) / 16 * 16 - 16;
            brushes.push(IBox::new([px, py, room.lo[2]], [px + 32, py + 32, room.hi[2]]));
        }
    }
    brushes.extend(steps);

    let first = rooms[0];
    let player_start =
        [(first.lo[0] + first.hi[0]) / 2 / 16 * 16 + 8, (first.lo[1] + first.hi[1]) / 2 / 16 * 16 + 8, 24];
    Layout { rooms, passages, brushes, player_start }
}

/// A corridor between neighbouring rooms `a` (lower coordinate) and `b` on the same floor.
fn corridor(a: &IBox, b: &IBox, along_x: bool, rng: &mut Rng) -> IBox {
    let (axis, across) = if along_x { (0, 1) } else { (1, 0) };
    // Both rooms cover [cell + MARGIN, cell + CELL - MARGIN] across the corridor.
    let cell = a.lo[across] - a.lo[across].rem_euclid(CELL);
    let start = rng.step(cell + MARGIN + WALL, cell + CELL - MARGIN - WALL - CORRIDOR_WIDTH, 16);
    let mut lo = [0; 3];
    let mut hi = [0; 3];
    lo[axis] = a.hi[axis] - WALL;
    hi[axis] = b.lo[axis] + WALL;
    lo[across] = start;
    hi[across] = start + CORRIDOR_WIDTH;
    lo[2] = a.lo[2];
    hi[2] = a.lo[2] + CORRIDOR_HEIGHT;
    IBox::new(lo, hi)
}

/// Shell every air box and carve every air box out of every slab.
fn carve(airs: &[IBox]) -> Vec<IBox> {
    let mut out = Vec::new();
    let mut pieces = Vec::new();
    let mut next = Vec::new();
    for air in airs {
        for slab in air.shell(WALL) {
            pieces.clear();
            pieces.push(slab);
            for cut in airs.iter().filter(|c| c.overlaps(&slab)) {
                next.clear();
                for p in &pieces {
                    p.minus(cut, &mut next);
                }
                std::mem::swap(&mut pieces, &mut next);
            }
            out.extend_from_slice(&pieces);
        }
    }
    out
}

/// One box brush; each side's points give a plane facing out of the box.
pub(crate) fn write_box(out: &mut String, b: &IBox, texture: &str) {
    write_box_at(out, b.lo, b.hi, texture);
}

/// One box brush from `lo` to `hi` (any coordinates that print as `.map` numbers); each side's
/// points give a plane facing out of the box.
pub fn write_box_at<T: Copy + std::fmt::Display>(out: &mut String, lo: [T; 3], hi: [T; 3], texture: &str) {
    let ([x0, y0, z0], [x1, y1, z1]) = (lo, hi);
    let sides = [
        [[x0, y0, z0], [x0, y1, z0], [x0, y0, z1]],
        [[x1, y0, z0], [x1, y0, z1], [x1, y1, z0]],
        [[x0, y0, z0], [x0, y0, z1], [x1, y0, z0]],
        [[x0, y1, z0], [x1, y1, z0], [x0, y1, z1]],
        [[x0, y0, z0], [x1, y0, z0], [x0, y1, z0]],
        [[x0, y0, z1], [x0, y1, z1], [x1, y0, z1]],
    ];
    out.push_str("{\n");
    for [p, q, r] in sides {
        let _ = writeln!(
            out,
            "( {} {} {} ) ( {} {} {} ) ( {} {} {} ) {texture} 0 0 0 1 1",
            p[0], p[1], p[2], q[0], q[1], q[2], r[0], r[1], r[2]
        );
    }
    out.push_str("}\n");
}

/// Two rooms along x joined by a doorway in the 16-unit wall between them, the doorway closed
/// by a 4-unit slab textured `blocker` across its middle: `skip` on every side makes it solid
/// without a drawn face, `wall` solid with faces, `clip` no obstacle to sight. Sealed as
/// [`generate`]'s maps are (walls are shells around the air boxes with every air box carved
/// out); an `info_player_start` at [`BLOCKED_ROOMS_SEER`] in the first room and a `light` at
/// [`BLOCKED_ROOMS_HIDDEN`] in the second keep both rooms.
pub fn blocked_rooms(blocker: &str) -> String {
    let rooms = [IBox::new([0, 0, 0], [256, 256, 128]), IBox::new([272, 0, 0], [528, 256, 128])];
    let door = IBox::new([256, 96, 0], [272, 160, 96]);
    let slab = IBox::new([262, 96, 0], [266, 160, 96]);
    let mut out = format!("// Generated by sightline mapgen: two rooms, the door closed by `{blocker}`\n");
    out.push_str("{\n\"classname\" \"worldspawn\"\n");
    for b in carve(&[rooms[0], rooms[1], door]) {
        write_box(&mut out, &b, "wall");
    }
    write_box(&mut out, &slab, blocker);
    out.push_str("}\n");
    for (class, [x, y, z]) in [("info_player_start", BLOCKED_ROOMS_SEER), ("light", BLOCKED_ROOMS_HIDDEN)] {
        let _ = writeln!(out, "{{\n\"classname\" \"{class}\"\n\"origin\" \"{x} {y} {z}\"\n}}");
    }
    out
}

/// A point in the first room of [`blocked_rooms`].
pub const BLOCKED_ROOMS_SEER: [i64; 3] = [120, 120, 24];
/// A point in the second room of [`blocked_rooms`], which sees the first only through the slab.
pub const BLOCKED_ROOMS_HIDDEN: [i64; 3] = [400, 120, 64];

/// Generate the `.map` text: worldspawn with every brush, an `info_player_start` in the first
/// room, and a `light` in every room.
pub fn generate(params: &MapGenParams) -> String {
    let layout = layout(params);
    let mut out = format!(
        "// Generated by sightline mapgen: {} x {} rooms, {} storeys, seed {}\n{{\n\"classname\" \"worldspawn\"\n",
        params.rooms_x, params.rooms_y, params.storeys, params.seed
    );
    for b in &layout.brushes {
        write_box(&mut out, b, "wall");
    }
    out.push_str("}\n");
    let [x, y, z] = layout.player_start;
    let _ = writeln!(out, "{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{x} {y} {z}\"\n}}");
    for room in &layout.rooms {
        let c = [(room.lo[0] + room.hi[0]) / 2, (room.lo[1] + room.hi[1]) / 2, room.hi[2] - 32];
        let _ = writeln!(out, "{{\n\"classname\" \"light\"\n\"origin\" \"{} {} {}\"\n}}", c[0], c[1], c[2]);
    }
    out
}

/// [`generate`]'s map with a TrenchBroom layer in it, from [`generate_with_layer`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayeredMap {
    /// The map with the layer.
    pub text: String,
    /// The same map with the layer (its `func_group`, its groups and its entities) removed by
    /// hand: [`generate`]'s text.
    pub without_layer: String,
    /// Brushes in the layer: its own, its groups' and its entities'.
    pub layer_brushes: usize,
    /// Entities in the layer, not counting the layer's and its groups' own `func_group`s.
    pub layer_entities: usize,
    /// 1-based line of the first entity in the layer that stands outside the sealed world.
    pub outside_line: u32,
}

/// `_tb_id` of the layer [`generate_with_layer`] adds.
pub const LAYER_ID: u32 = 1;

/// [`generate`]'s map with a TrenchBroom layer `"scaffold"` (`_tb_id` [`LAYER_ID`], omitted from
/// export when `omit`), as TrenchBroom saves one: a `func_group` with `"_tb_type" "_tb_layer"`
/// right after `worldspawn`, holding a wall across the first room (16 units thick, floor to
/// ceiling, 48 units to the −x of the player start); a `light` with `"_tb_layer"` 512 units
/// beyond every brush (in the void); and a group in the layer (a pillar by the player start) holding
/// a nested group (a floating cube) whose members are another `light` in the void and a
/// `func_wall` (a low block beyond the wall). Compiled, the layer splits the room and leaks.
pub fn generate_with_layer(params: &MapGenParams, omit: bool) -> LayeredMap {
    let layout = layout(params);
    let without_layer = generate(params);
    let room = layout.rooms[0];
    let [px, py, _] = layout.player_start;
    let (x, y) = (px - 8, py - 8);
    let (floor, ceiling) = (room.lo[2], room.hi[2]);
    let beyond = layout.brushes.iter().map(|b| b.hi[0]).max().unwrap_or(0) + 512;
    let omit_key = if omit { "\"_tb_layer_omit_from_export\" \"1\"\n" } else { "" };
    let mut layer = format!(
        "{{\n\"classname\" \"func_group\"\n\"_tb_type\" \"_tb_layer\"\n\"_tb_name\" \"scaffold\"\n\
         \"_tb_id\" \"{LAYER_ID}\"\n\"_tb_layer_sort_index\" \"0\"\n{omit_key}"
    );
    write_box(&mut layer, &IBox::new([x - 48, room.lo[1], floor], [x - 32, room.hi[1], ceiling]), "wall");
    layer.push_str("}\n");
    let mut groups = format!(
        "{{\n\"classname\" \"func_group\"\n\"_tb_type\" \"_tb_group\"\n\"_tb_name\" \"props\"\n\
         \"_tb_id\" \"2\"\n\"_tb_layer\" \"{LAYER_ID}\"\n"
    );
    write_box(&mut groups, &IBox::new([x + 32, y + 32, floor], [x + 48, y + 48, ceiling]), "wall");
    groups.push_str(
        "}\n{\n\"classname\" \"func_group\"\n\"_tb_type\" \"_tb_group\"\n\"_tb_name\" \"inner\"\n\
         \"_tb_id\" \"3\"\n\"_tb_group\" \"2\"\n",
    );
    write_box(&mut groups, &IBox::new([x + 48, y - 64, floor + 32], [x + 64, y - 48, floor + 48]), "wall");
    let _ = write!(
        groups,
        "}}\n{{\n\"classname\" \"light\"\n\"origin\" \"{beyond} {py} 64\"\n\"_tb_group\" \"3\"\n}}\n\
         {{\n\"classname\" \"func_wall\"\n\"_tb_group\" \"3\"\n"
    );
    write_box(&mut groups, &IBox::new([x - 80, y + 32, floor], [x - 64, y + 48, floor + 16]), "wall");
    groups.push_str("}\n");
    let light = format!(
        "{{\n\"classname\" \"light\"\n\"origin\" \"{beyond} {py} 32\"\n\"_tb_layer\" \"{LAYER_ID}\"\n}}\n"
    );
    // Layer after worldspawn, groups after the player start, the light last.
    let world_end = without_layer.find("}\n{\n\"classname\" \"info_player_start\"").map_or(0, |i| i + 2);
    let start_end = world_end + without_layer[world_end..].find("}\n").map_or(0, |i| i + 2);
    let text = format!(
        "{}{layer}{}{groups}{}{light}",
        &without_layer[..world_end],
        &without_layer[world_end..start_end],
        &without_layer[start_end..]
    );
    let line_of = |at: usize| text[..at].lines().count() as u32 + 1;
    let first_outside = format!("{{\n\"classname\" \"light\"\n\"origin\" \"{beyond} ");
    let outside_line = text.find(&first_outside).map_or(0, line_of);
    LayeredMap { text, without_layer, layer_brushes: 4, layer_entities: 3, outside_line }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_minus_covers_exactly_the_difference() {
        let a = IBox::new([0, 0, 0], [64, 64, 64]);
        let b = IBox::new([16, -16, 16], [32, 80, 48]);
        let mut out = Vec::new();
        a.minus(&b, &mut out);
        let volume = |b: &IBox| (0..3).map(|i| b.hi[i] - b.lo[i]).product::<i64>();
        assert_eq!(out.iter().map(volume).sum::<i64>(), 64 * 64 * 64 - 16 * 64 * 32);
        assert!(out.iter().all(|p| !p.overlaps(&b) && volume(p) > 0));
        for (i, p) in out.iter().enumerate() {
            assert!(out[i + 1..].iter().all(|q| !p.overlaps(q)));
        }
    }

    #[test]
    fn same_seed_same_text_other_seed_other_text() {
        let p = MapGenParams { rooms_x: 3, rooms_y: 2, storeys: 2, seed: 7 };
        assert_eq!(generate(&p), generate(&p));
        assert_ne!(generate(&p), generate(&MapGenParams { seed: 8, ..p }));
    }

    #[test]
    fn coordinates_are_multiples_of_16() {
        let l = layout(&MapGenParams { rooms_x: 4, rooms_y: 3, storeys: 3, seed: 1 });
        assert!(
            l.brushes.iter().chain(&l.rooms).chain(&l.passages).all(|b| {
                b.lo.iter().chain(&b.hi).all(|c| c % 16 == 0) && (0..3).all(|i| b.lo[i] < b.hi[i])
            })
        );
        assert!(l.player_start.iter().all(|c| c.rem_euclid(16) == 8));
    }
}
