//! Guided visibility sampling of one box view cell (Wonka et al. 2006, with the extensions of the
//! thesis digested in `reference/seeds/000_gvs_thesis.md`).
//!
//! The loop: a quasi-random ray leaves the cell ([`Cell::sample_ray`], through `Halton5`); every ray whose first hit
//! is a triangle not yet in the PVS adds it (with the ray's origin and hit point) and queues it as a
//! seed. Each seed gets adaptive border sampling (ABS): rays from the seed's origin to the nine
//! points of the enlarged outline (`enlarge`) and along its nine edges, either by recursive
//! bisection (stock GVS, depth-capped, optionally with a distance-scaled threshold) or by the
//! edge-point walk (one ray per object along the edge). Every point and edge ray is checked for a
//! depth discontinuity (hit much nearer than the aimed point); a discontinuity starts reverse
//! sampling: a ray in the plane (origin, aimed point, seed hit) grazing the occluder's edge, started
//! from where that line leaves the cell. Sampling stops when a window of rays found too few new
//! triangles, or at the ray caps.
//!
//! Options beyond stock GVS ([`Params`]): the thesis' "first" strategy (a batch of random rays
//! before any ABS), and this project's neighbour probing (`probe`: slivers next to a found
//! surface, seen from other corners of the cell), target sampling (`targets`: rays at groups of
//! nearby triangles none of which was found, after random sampling) and silhouette re-seeding
//! (`silhouette`).
//!
//! Runs are sequential and deterministic: the same scene, cell and [`Params`] give the same PVS.

mod abs;
mod edge;
mod params;
mod probe;
mod random;
mod reverse;
mod target;
#[cfg(test)]
mod tests;

pub use params::{EdgeMode, ParamError, Params};
pub use probe::PROBE_RAYS;
pub use target::TARGET_RAYS;

use std::collections::VecDeque;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;
use sightline_formats::bits;
use sightline_raycast::Bvh;

use crate::SceneIndex;
use crate::components::Components;
use crate::geom::Cell;
use crate::geom::Halton5;
use crate::neighbours::Neighbours;
use crate::targets::TargetGroups;
use probe::PROBE_SEQ_OFFSET;

/// Ray counts and other statistics of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stats {
    /// All rays cast.
    pub rays: u64,
    /// Random rays.
    pub random: u64,
    /// Rays to the points of enlarged outlines.
    pub point: u64,
    /// Rays along outline edges.
    pub edge: u64,
    /// Reverse-sampling rays.
    pub reverse: u64,
    /// Rays re-cast at a previous PVS's hit points (incremental update).
    pub reuse: u64,
    /// Silhouette re-seeding rays.
    pub silhouette: u64,
    /// Neighbour probing rays.
    pub probe: u64,
    /// Target sampling rays.
    pub target: u64,
    /// Depth discontinuities detected.
    pub discontinuities: u64,
    /// Seeds processed by ABS.
    pub seeds: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// The run stopped at [`Params::max_rays`]: seeds left unsampled or target sampling cut
    /// short, so the PVS may miss triangles a longer run would find.
    pub capped: bool,
}

/// One PVS entry: a triangle and the ray that found it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// Triangle index.
    pub tri: u32,
    /// Origin of the ray that found it (on or in the cell).
    pub origin: Vec3,
    /// Where that ray hit it.
    pub hit: Vec3,
}

/// The result of GVS for one cell: the PVS in discovery order, with the rays that found it.
#[derive(Debug, Clone)]
pub struct Pvs {
    /// The cell.
    pub cell: Cell,
    /// Entries in discovery order.
    pub entries: Vec<Entry>,
    /// Statistics.
    pub stats: Stats,
}

impl Pvs {
    /// Membership bitset over `n` triangles.
    pub fn bitset(&self, n: usize) -> Vec<u64> {
        let mut row = vec![0u64; bits::words(n)];
        for e in &self.entries {
            bits::set(&mut row, e.tri as usize);
        }
        row
    }

    /// Triangle indices, sorted.
    pub fn sorted(&self) -> Vec<u32> {
        let mut v: Vec<u32> = self.entries.iter().map(|e| e.tri).collect();
        v.sort_unstable();
        v
    }
}

/// Kinds of ray, for statistics.
#[derive(Debug, Clone, Copy)]
pub(super) enum Class {
    Random,
    Point,
    Edge,
    Reverse,
    Reuse,
    Silhouette,
    Probe,
    Target,
}

/// No triangle: the ray escaped.
const NONE: u32 = u32::MAX;

/// A cast ray `o + t dir`: what it hit (`NONE` for nothing), where (the aimed point `o + dir`
/// when nothing), and the ray parameter there (1 when nothing).
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub(super) tri: u32,
    pub(super) pos: Vec3,
    pub(super) t: f32,
}

/// A queued ABS seed.
#[derive(Debug, Clone, Copy)]
struct Seed {
    origin: Vec3,
    tri: u32,
    hit: Vec3,
}

/// `probe_state` bit: the triangle was probed as a neighbour.
const PROBED: u8 = 1;
/// `probe_state` bit: the triangle's neighbours were probed.
const EXPANDED: u8 = 2;
/// [`Gvs::sheet_side`]: seen from the side its normal points to.
const SEEN_FRONT: u8 = 1;
/// [`Gvs::sheet_side`]: seen from behind.
const SEEN_BACK: u8 = 2;

/// The sampler's state for one cell.
#[derive(Debug)]
pub(super) struct Gvs<'a> {
    tris: &'a [[Vec3; 3]],
    bvh: &'a Bvh,
    neighbours: &'a Neighbours,
    components: &'a Components,
    targets: &'a TargetGroups,
    pub(super) cell: Cell,
    pub(super) p: Params,
    in_pvs: Vec<u64>,
    /// Per triangle, the cell corners silhouette re-seeding has tried (bit k = corner k); empty
    /// without silhouette re-seeding.
    tried: Vec<u8>,
    /// Per triangle, neighbour probing state: [`PROBED`], [`EXPANDED`].
    probe_state: Vec<u8>,
    /// Per sheet (indexed by the triangle naming it), the side its naming triangle was first seen
    /// from: 0 not yet, [`SEEN_FRONT`] or [`SEEN_BACK`]; empty without probing.
    sheet_side: Vec<u8>,
    /// Scratch list of probe candidates.
    candidates: Vec<u32>,
    pub(super) entries: Vec<Entry>,
    queue: VecDeque<Seed>,
    pub(super) stats: Stats,
    /// Rays cast when the current termination window began, and new triangles found since.
    window_start: u64,
    window_new: u32,
    /// Every ray cast, as `(origin, direction)`, when recording ([`run_recorded`]).
    record: Option<Vec<(Vec3, Vec3)>>,
    /// Neighbour probing's random rays: (cell point, point in the probed triangle).
    probe_seq: Halton5,
}

impl<'a> Gvs<'a> {
    pub(super) fn new(index: &'a SceneIndex, cell: Cell, p: Params) -> Gvs<'a> {
        let tris = index.tris;
        Gvs {
            tris,
            bvh: &index.bvh,
            neighbours: &index.neighbours,
            components: &index.components,
            targets: &index.targets,
            cell,
            p,
            in_pvs: vec![0; bits::words(tris.len())],
            tried: vec![0; if p.silhouette { tris.len() } else { 0 }],
            probe_state: vec![0; if p.probe { tris.len() } else { 0 }],
            sheet_side: vec![0; if p.probe { tris.len() } else { 0 }],
            candidates: Vec::new(),
            entries: Vec::new(),
            queue: VecDeque::new(),
            stats: Stats::default(),
            window_start: 0,
            window_new: 0,
            record: None,
            probe_seq: Halton5::new(p.seed.wrapping_add(PROBE_SEQ_OFFSET)),
        }
    }

    /// True when `tri` is in the PVS.
    fn has(&self, tri: u32) -> bool {
        bits::get(&self.in_pvs, tri as usize)
    }

    /// Add `tri` to the PVS; returns false when it was there already.
    pub(super) fn insert(&mut self, tri: u32, origin: Vec3, hit: Vec3) -> bool {
        let Some(w) = self.in_pvs.get_mut(bits::word_of(tri as usize)) else {
            return false;
        };
        let bit = bits::mask(tri as usize);
        if *w & bit != 0 {
            return false;
        }
        *w |= bit;
        self.entries.push(Entry { tri, origin, hit });
        self.window_new += 1;
        true
    }

    fn out_of_rays(&self) -> bool {
        self.stats.rays >= self.p.max_rays
    }

    /// Cast one ray from `o` towards `target` without touching the PVS.
    pub(super) fn cast(&mut self, o: Vec3, dir: Vec3, class: Class) -> Sample {
        self.stats.rays += 1;
        match class {
            Class::Random => self.stats.random += 1,
            Class::Point => self.stats.point += 1,
            Class::Edge => self.stats.edge += 1,
            Class::Reverse => self.stats.reverse += 1,
            Class::Reuse => self.stats.reuse += 1,
            Class::Silhouette => self.stats.silhouette += 1,
            Class::Probe => self.stats.probe += 1,
            Class::Target => self.stats.target += 1,
        }
        if let Some(r) = &mut self.record {
            r.push((o, dir));
        }
        match self.bvh.intersect(o, dir, f32::INFINITY) {
            Some(h) => Sample { tri: h.triangle, pos: o + dir * h.t, t: h.t },
            None => Sample { tri: NONE, pos: o + dir, t: 1.0 },
        }
    }

    /// Cast, and add a new triangle to the PVS and the seed queue (`handle_ray`).
    pub(super) fn handle(&mut self, o: Vec3, dir: Vec3, class: Class) -> Sample {
        let s = self.cast(o, dir, class);
        if s.tri != NONE && self.insert(s.tri, o, s.pos) {
            self.queue.push_back(Seed { origin: o, tri: s.tri, hit: s.pos });
        }
        s
    }

    /// Queue an existing PVS entry for ABS (incremental update of new triangles).
    pub(super) fn enqueue(&mut self, origin: Vec3, tri: u32, hit: Vec3) {
        self.queue.push_back(Seed { origin, tri, hit });
    }
}

/// Run GVS for `cell` over the triangles of `index`.
pub fn run(index: &SceneIndex, cell: Cell, params: Params) -> Pvs {
    run_with(index, cell, params, false).0
}

/// [`run`], also returning every ray it cast as `(origin, direction)` in casting order (for
/// benchmarks that time the ray casting alone against the whole run). The PVS is the same.
pub fn run_recorded(index: &SceneIndex, cell: Cell, params: Params) -> (Pvs, Vec<(Vec3, Vec3)>) {
    let (pvs, rays) = run_with(index, cell, params, true);
    (pvs, rays.unwrap_or_default())
}

fn run_with(
    index: &SceneIndex,
    cell: Cell,
    params: Params,
    record: bool,
) -> (Pvs, Option<Vec<(Vec3, Vec3)>>) {
    let start = Instant::now();
    let mut g = Gvs::new(index, cell, params);
    g.record = record.then(Vec::new);
    g.run();
    g.stats.seconds = start.elapsed().as_secs_f64();
    (Pvs { cell, entries: g.entries, stats: g.stats }, g.record)
}
