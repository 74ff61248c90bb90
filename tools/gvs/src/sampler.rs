//! Guided visibility sampling of one box view cell (Wonka et al. 2006, with the extensions of the
//! thesis digested in `reference/seeds/000_gvs_thesis.md`).
//!
//! The loop: a quasi-random ray leaves the cell ([`Cell::sample_ray`], through [`Halton5`]); every ray whose first hit
//! is a triangle not yet in the PVS adds it (with the ray's origin and hit point) and queues it as a
//! seed. Each seed gets adaptive border sampling (ABS): rays from the seed's origin to the nine
//! points of the enlarged outline ([`enlarge`]) and along its nine edges, either by recursive
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

use std::collections::VecDeque;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;
use sightline_formats::bits;
use sightline_raycast::{Bvh, intersect_brute};

use super::SceneIndex;
use super::components::Components;
use super::neighbours::{Neighbours, touching_box};
use super::targets::TargetGroups;

use super::geom::{Cell, Fan, Halton5, enlarge};

/// How ABS samples the edges of the enlarged outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum EdgeMode {
    /// Recursive bisection while the two end rays hit different triangles (stock GVS).
    Bisect,
    /// The thesis' edge-point walk ("brzegowy"): from one end, jump just past the boundary of the
    /// object hit there, one ray per distinct object; bisection only where both ends miss.
    EdgePoint,
}

/// GVS parameters. Defaults (see [`Params::default`]) are the "stock" configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Params {
    /// Angular offset of the enlarged outline (radians). Default 1e-3.
    pub eps: f32,
    /// Edge sampling strategy. Default [`EdgeMode::Bisect`].
    pub edge: EdgeMode,
    /// Deepest bisection of an outline edge (the thesis' `tresh ≈ 2^-14` is depth 14). Default 14.
    pub max_depth: u32,
    /// Distance-scaled threshold ("adt"): stop bisecting a segment whose angular size seen from the
    /// origin is under this (radians). `None` disables it. Default `None`.
    pub adt: Option<f32>,
    /// Cast a ray at the middle of every outline edge before walking it (edge-point mode only).
    /// Default true.
    pub midpoint: bool,
    /// A hit nearer than the aimed point by more than this fraction of the aimed distance is a
    /// depth discontinuity. Default 0.05.
    pub disc: f32,
    /// Reverse sampling at discontinuities. Default true.
    pub reverse: bool,
    /// Silhouette re-seeding (see `Gvs::reseed_silhouette`; not in the thesis). Default false.
    pub silhouette: bool,
    /// Neighbour probing (see `Gvs::probe_neighbours`; not in the thesis). Default false.
    pub probe: bool,
    /// Rays neighbour probing casts at a probed triangle its fixed rays missed, each from a
    /// random point of the cell in front of it at a random point of it. Default [`PROBE_RAYS`].
    pub probe_rays: u32,
    /// Target sampling (see `Gvs::sample_targets`; not in the thesis): triangles aimed at per
    /// group of nearby triangles with unreached surface components, each by up to `target_rays`
    /// rays, once random sampling has ended. 0 disables it. Default 0.
    pub targets: u32,
    /// Most rays target sampling aims at one triangle. Default [`TARGET_RAYS`].
    pub target_rays: u32,
    /// The thesis' "first" random-ray strategy: cast this many random rays before any ABS (their
    /// new triangles queue up as seeds), then go on as usual. 0 is the stock "last" strategy
    /// (random rays only when the queue is empty). Default 0.
    pub first: u64,
    /// Cap on all rays. Default 10 M (the thesis' cap). It is checked between steps, so a run
    /// may pass it by the few rays of one step (a seed's nine outline rays); a run that reaches
    /// it says so in [`Stats::capped`].
    pub max_rays: u64,
    /// Cap on random rays. Default 1 M.
    pub max_random: u64,
    /// Termination window: stop when the last `window` rays found fewer than `min_new` new
    /// triangles. Default 25 k (measured: on the generated city and sphere scenes 25 k gives the
    /// same PVS and pixel error as 100 k, for a quarter of the proof rays).
    pub window: u64,
    /// See `window`. Default 1.
    pub min_new: u32,
    /// First Halton index of the random rays (different seeds give different ray sets). Default 1.
    pub seed: u64,
}

impl Default for Params {
    fn default() -> Params {
        Params {
            eps: 1e-3,
            edge: EdgeMode::Bisect,
            max_depth: 14,
            adt: None,
            midpoint: true,
            disc: 0.05,
            reverse: true,
            silhouette: false,
            probe: false,
            probe_rays: PROBE_RAYS,
            targets: 0,
            target_rays: TARGET_RAYS,
            first: 0,
            max_rays: 10_000_000,
            max_random: 1_000_000,
            window: 25_000,
            min_new: 1,
            seed: 1,
        }
    }
}

/// A [`Params`] field outside the range its documentation gives.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// `eps` is not in (0, 1] radians.
    #[error("eps {0}: the enlarged outline's angular offset must be in (0, 1] radians")]
    Eps(f32),
    /// `disc` is not in [0, 1).
    #[error("disc {0}: the relative depth-discontinuity threshold must be in [0, 1)")]
    Disc(f32),
    /// `adt` is not a positive, finite angle.
    #[error("adt {0}: the distance-scaled threshold must be a positive number of radians")]
    Adt(f32),
}

impl Params {
    /// Check the ranges of the floating-point fields: `eps` in (0, 1], `disc` in [0, 1), `adt`
    /// positive and finite. A NaN in any of them would not fail a run but silently turn a part of
    /// GVS off (a NaN `eps` casts no edge rays, a NaN `disc` finds no discontinuity), so callers
    /// taking parameters from users check them first. The integer fields have no invalid values:
    /// `max_rays` bounds every run.
    pub fn check(&self) -> Result<(), ParamError> {
        if !(self.eps > 0.0 && self.eps <= 1.0) {
            return Err(ParamError::Eps(self.eps));
        }
        if !(self.disc >= 0.0 && self.disc < 1.0) {
            return Err(ParamError::Disc(self.disc));
        }
        match self.adt {
            Some(a) if !(a > 0.0 && a.is_finite()) => Err(ParamError::Adt(a)),
            _ => Ok(()),
        }
    }
}

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

/// Default of [`Params::target_rays`], the most rays target sampling aims at one triangle (from
/// as many points of the cell: an object seen through a gap from part of the cell only). Measured on `gen:mixed:2000` (5 cells, 50
/// views), targets × rays per target: 4 × 4 (the earlier rule) 7.1 wrong pixels per view, 4 × 8
/// 5.2, 4 × 16 3.1, 4 × 32 3.7, 4 × 64 3.0: past 16 the differences are sampling noise; over 10
/// cells of 8 units, 4 × 4 10.5 (5.3 counted per object), 3 × 12 5.2 (0.02), 2 × 16 5.3 (0.06).
pub const TARGET_RAYS: u32 = 16;

/// Most candidate rays target sampling draws per target ray once a ray at the target has been
/// hidden: it casts the first that crosses none of the bounding boxes of the components seen
/// hiding the target so far, or the one crossing fewest; when none missed them all, the target's
/// remaining rays are drawn in order (at the thesis' sphere density nearly every target is hidden
/// from the whole cell, and drawing 64 candidates per ray made a cell 1.2 times as long). Measured
/// on `gen:mixed:2000` (six scene seeds, the 5 suggested cells and the same cells moved by a
/// quarter, 50 views each), wrong pixels per view without this ranking → with it: 2.90 → 2.54
/// per triangle, 2.15 → 1.80 per object (configurations with a whole object of over 150 pixels
/// missed: 4 → 1), for the same number of rays.
const TARGET_TRIES: usize = 64;

/// True when the segment `o`..`o + d` crosses box `b`; `inv` is `1 / d`. A plain slab test
/// without [`Cell::clip`]'s care for zero components: it only ranks target sampling's candidates.
fn crosses(b: &Cell, o: Vec3, inv: Vec3) -> bool {
    let (t0, t1) = ((b.min - o) * inv, (b.max - o) * inv);
    t0.min(t1).max_element().max(0.0) <= t0.max(t1).min_element().min(1.0)
}

/// Probe points (of the nine in `Gvs::probe`'s order) that also aim near a probed triangle's
/// corners; the last four corners aim at its centre only. Measured on the default variant (5
/// cells, 50 views) against all nine aiming near the corners, rays more than with five points
/// only: city +1.9 % against +5.1 % (0.0 px either way; the moved cell's 90 px tile found by
/// both), `spheres:1000` +0.5 % against +2.0 % (0.5 against 0.4 px), `mixed:2000` +0.4 %
/// against +1.5 % (2.4 against 1.2 px), `spheres:10116` +3.2 % against +16 % (error no better).
const PROBE_FULL: usize = 5;

/// Fraction of the way from a probed triangle's corner to its centre where the corner rays aim.
const PROBE_INSET: f32 = 0.1;

/// Default of [`Params::probe_rays`]. The fixed probe rays start at the cell's corners and centre
/// only, so a triangle seen through a gap from the cell's inside alone gets no ray through it
/// (slivers of spheres seen between nearer ones). Measured on the default variant, wrong pixels per view and rays, 0 → 4 → 8:
/// twelve Quake levels (100 leaf cells each, 500 × 500 px) 0.227 → 0.197 → 0.190 px, +1.3 %,
/// +2.6 % rays; `spheres:1000` (5 cells, 250 views) 0.89 → 0.49 → 0.46 px, +0.6 %, +1.2 %;
/// `mixed:2000` 1.56 → 1.52 → 1.47 px; the city 0.02 px throughout, +1.1 %, +2.1 %; the thesis'
/// density (`spheres:10116`) 0 → 8: 83.3 → 45.2 px per triangle, +9 % rays. Time per cell
/// 1.01–1.03× on the spheres and the city (paired runs).
pub const PROBE_RAYS: u32 = 8;

/// First Halton index of neighbour probing's random rays, past the cell's seed: far from the
/// random rays' indices (at most [`Params::max_random`] from the seed), so the two never reuse
/// points.
const PROBE_SEQ_OFFSET: u64 = 1 << 32;

/// Most Halton points drawn per random probe ray (points behind the probed triangle's front are
/// skipped, so a triangle seen edge-on from the cell costs bounded work).
const PROBE_TRIES: u32 = 4;

/// Most steps of one edge-point walk before it gives up.
const WALK_STEPS: u32 = 64;

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

    /// Run until termination: drain the queue, then random rays, checking the window.
    pub(super) fn run(&mut self) {
        // The Halton index starts at the seed (any `u64`, so it wraps past the end).
        let mut halton = Halton5::new(self.p.seed.max(1));
        // "first": all the initial random rays before any ABS.
        // They are cast in order of direction (a fixed, stable order): coherent rays traverse the
        // BVH about twice as fast as scattered ones.
        let first = self.p.first.min(self.p.max_random).min(self.p.max_rays);
        if first > 0 {
            let batch: Vec<(Vec3, Vec3)> =
                (0..first).map(|_| self.cell.ray_at(halton.next_point())).collect();
            // A counting sort on 16³ direction bins: stable, linear.
            let bin = |d: Vec3| {
                let q = |x: f32| ((x + 1.0) * 8.0).clamp(0.0, 15.0) as usize;
                (q(d.z) << 8) | (q(d.y) << 4) | q(d.x)
            };
            let mut start = vec![0usize; 4097];
            for (_, d) in &batch {
                start[bin(*d) + 1] += 1;
            }
            for k in 1..start.len() {
                start[k] += start[k - 1];
            }
            // Scattered into place, then read in order (reading the batch through an index
            // missed the cache on every ray).
            let mut sorted = vec![(Vec3::ZERO, Vec3::ZERO); batch.len()];
            for &(o, d) in &batch {
                let b = bin(d);
                sorted[start[b]] = (o, d);
                start[b] += 1;
            }
            for (o, d) in sorted {
                self.handle(o, d, Class::Random);
            }
        }
        loop {
            while let Some(seed) = self.queue.pop_front() {
                if self.out_of_rays() {
                    self.queue.clear();
                    break;
                }
                self.abs(seed);
            }
            if self.out_of_rays() || self.stats.random >= self.p.max_random {
                break;
            }
            if self.stats.rays - self.window_start >= self.p.window {
                if self.window_new < self.p.min_new {
                    break;
                }
                self.window_start = self.stats.rays;
                self.window_new = 0;
            }
            let (o, d) = self.cell.ray_at(halton.next_point());
            self.handle(o, d, Class::Random);
        }
        if self.p.targets > 0 && !self.out_of_rays() {
            self.sample_targets();
            while let Some(seed) = self.queue.pop_front() {
                if self.out_of_rays() {
                    self.queue.clear();
                    break;
                }
                self.abs(seed);
            }
        }
        self.stats.capped = self.out_of_rays();
    }

    /// Target sampling (this project's extension, "target"): random rays rarely hit small
    /// isolated objects far away (the thesis' Table 6 misses at the scene's periphery: neither
    /// connected surfaces nor occluders, so ABS and reverse sampling never reach them), nor lone
    /// triangles among found objects. Once random sampling has ended, every group of nearby
    /// triangles ([`TargetGroups`], built once per scene) with triangles of unreached surface
    /// components (no triangle of theirs in the PVS; see [`Components`]) has `targets` of those
    /// triangles (spread over them) aimed at, each by up to `target_rays` rays until its
    /// component is reached: from points of the cell (Halton over the cell's volume), at its
    /// centre and then at points inside it (an object seen through a gap from part of the cell,
    /// a lone triangle half hidden from one point of the cell). A ray that ends on another
    /// component before the target makes that component's bounding box an occluder of the
    /// target, and each next ray is the
    /// first of up to [`TARGET_TRIES`] candidates crossing none of the target's occluders, or the
    /// one crossing fewest (it steers the rays into the gaps between known occluders; it never
    /// stops a ray being cast). What they hit joins the PVS and gets ABS as usual. The cost is bounded by the number of groups times
    /// `targets × target_rays`, whatever their distance; a group whose components are all reached
    /// costs one look per component. Without a component table, a group is unreached when none of
    /// its triangles is in the PVS, and a target is done when it is in the PVS; without target
    /// groups, nothing is cast.
    fn sample_targets(&mut self) {
        let comps = self.components;
        let mut reached = comps.reached(self.entries.iter().map(|e| e.tri));
        let unreached = |reached: &[bool], c: u32| reached.get(c as usize) == Some(&false);
        // A target is done when its component is reached (without components: when it is found).
        let done = |g: &Gvs, reached: &[bool], t: u32| {
            if comps.is_empty() { g.has(t) } else { !unreached(reached, comps.of(t)) }
        };
        let k = self.p.targets as usize;
        let mut todo: Vec<u32> = Vec::new();
        let mut cand: Vec<u32> = Vec::new();
        for (g, g_comps) in self.targets.iter() {
            cand.clear();
            if comps.is_empty() {
                if !g.iter().any(|&t| self.has(t)) {
                    cand.extend_from_slice(g);
                }
            } else if g_comps.iter().any(|&c| unreached(&reached, c)) {
                cand.extend(g.iter().filter(|&&t| unreached(&reached, comps.of(t))));
            }
            let k = k.min(cand.len());
            todo.extend((0..k).filter_map(|j| cand.get(j * cand.len() / k)));
        }
        // One Halton sequence over (cell point, point in the target) for all candidates.
        let mut seq = Halton5::new(1);
        // The components seen hiding the current target.
        let mut occluders: Vec<u32> = Vec::new();
        for &t in &todo {
            let Some(tri) = self.tris.get(t as usize) else {
                continue;
            };
            let own = comps.of(t);
            occluders.clear();
            // Steering stops when no candidate of a ray missed the known occluders (they cover
            // the cell's view of the target; the rest of its rays are drawn in order).
            let mut steer = true;
            for r in 0..self.p.target_rays {
                if self.out_of_rays() || done(self, &reached, t) {
                    break;
                }
                // The candidate ray crossing the fewest boxes of the components seen hiding this
                // target so far (the first with none), of up to `TARGET_TRIES`: from a point of
                // the cell, at the target's centre first and then at points inside it.
                let mut best: Option<(usize, Vec3, Vec3)> = None;
                for _ in 0..if occluders.is_empty() || !steer { 1 } else { TARGET_TRIES } {
                    let (o, inside) = self.cell.segment_to(tri, seq.next_point());
                    let aim = if r == 0 { (tri[0] + tri[1] + tri[2]) / 3.0 } else { inside };
                    let crossed = if occluders.is_empty() {
                        0
                    } else {
                        let inv = (aim - o).recip();
                        occluders
                            .iter()
                            .filter_map(|&c| comps.bounds(c))
                            .filter(|b| crosses(b, o, inv))
                            .count()
                    };
                    if best.is_none_or(|(c, _, _)| crossed < c) {
                        best = Some((crossed, o, aim));
                    }
                    if crossed == 0 {
                        break;
                    }
                }
                let Some((crossed, o, aim)) = best else {
                    break;
                };
                steer &= crossed == 0;
                let s = self.handle(o, aim - o, Class::Target);
                // A hit reaches its component (`NONE`, an escaped ray, reaches none).
                let hit = comps.of(s.tri);
                if let Some(r) = reached.get_mut(hit as usize) {
                    *r = true;
                }
                // Another component hit before the aimed point hides it from this origin.
                if hit != own && hit != Components::NONE && s.t < 1.0 && !occluders.contains(&hit) {
                    occluders.push(hit);
                }
            }
        }
    }

    /// Adaptive border sampling around a seed.
    fn abs(&mut self, seed: Seed) {
        self.stats.seeds += 1;
        let Some(tri) = self.tris.get(seed.tri as usize) else {
            return;
        };
        let o = seed.origin;
        let pts = enlarge(tri, o, self.p.eps);
        let samples = pts.map(|p| {
            let s = self.handle(o, p - o, Class::Point);
            self.check_discontinuity(o, p, s, seed.hit);
            s
        });
        if self.p.silhouette {
            self.reseed_silhouette(seed, tri, &pts, &samples);
        }
        for i in 0..9 {
            let j = (i + 1) % 9;
            match self.p.edge {
                EdgeMode::Bisect => self.bisect(o, pts[i], samples[i], pts[j], samples[j], 0, seed.hit),
                EdgeMode::EdgePoint => self.walk_edge(o, pts[i], samples[i], pts[j], samples[j], seed.hit),
            }
        }
        if self.p.probe {
            self.probe_neighbours(seed.tri, tri, o);
        }
    }

    /// Neighbour probing (this project's extension, "probe"): every triangle touching a PVS
    /// triangle's box (its mesh neighbours, found through the BVH) that is not in the PVS yet is
    /// probed once. Its front is the side it is expected to be seen from: the side the expanded
    /// triangle was seen from, carried over through the windings of their sheet
    /// ([`super::sheets`]); for a triangle of another sheet, the side that sheet was first seen
    /// from in this cell; failing both, the side `(v1 - v0) × (v2 - v0)` points to (triangles
    /// counter-clockwise seen from the front, as in `.obj` meshes and in
    /// [`super::scene::from_level`]'s triangles). It is probed from points in front of its
    /// plane (the cell corner furthest in front, the
    /// cell's centre, the three corners next to that corner), one after the other until it is
    /// found, a ray at its centre and then rays near its three corners (those that do not cross
    /// the triangle which hid its centre from that point); then from the other four
    /// corners in front, a ray at its centre (what only one edge of the cell sees: a city facade
    /// tile 90 px large in a moved cell's view); from the corner furthest behind its plane, one
    /// ray at its centre; last, up to [`Params::probe_rays`] rays from random points of the cell
    /// in front of it at random points of it (Halton), for what is seen only through a gap from
    /// the cell's inside. This finds the slivers next to a
    /// surface's silhouette that only part of the cell sees (seen nearly edge-on, or from the
    /// back from the seed's origin), which ABS from one origin misses. A probed triangle that is
    /// hit joins the PVS and is queued from that corner, so ABS and probing continue from there.
    pub(super) fn probe_neighbours(&mut self, t: u32, tri: &[Vec3; 3], seen_from: Vec3) {
        let Some(state) = self.probe_state.get_mut(t as usize) else {
            return;
        };
        if *state & EXPANDED != 0 {
            return;
        }
        *state |= EXPANDED;
        // The table's row, or (a crowded triangle) the BVH query it stands for.
        let table = self.neighbours;
        let mut cand = std::mem::take(&mut self.candidates);
        cand.clear();
        let list = match table.of(t) {
            Some(row) => row,
            None => {
                let (lo, hi) = touching_box(tri);
                self.bvh.overlapping(lo, hi, |u| {
                    cand.push(u);
                    true
                });
                &cand[..]
            }
        };
        let seen_back = (tri[1] - tri[0]).cross(tri[2] - tri[0]).dot(seen_from - tri[0]) < 0.0;
        let sheet = self.neighbours.sheets().of(t);
        if let Some((s, flipped)) = sheet
            && let Some(side) = self.sheet_side.get_mut(s as usize)
            && *side == 0
        {
            *side = if seen_back != flipped { SEEN_BACK } else { SEEN_FRONT };
        }
        for &u in list {
            self.probe(u, sheet, seen_back);
        }
        self.candidates = cand;
    }

    /// Probe the neighbour `u` once (see [`Gvs::probe_neighbours`]), unless it is in the PVS.
    fn probe(&mut self, u: u32, t_sheet: Option<(u32, bool)>, t_back: bool) {
        if self.has(u) || self.out_of_rays() {
            return;
        }
        let (Some(state), Some(ut)) = (self.probe_state.get_mut(u as usize), self.tris.get(u as usize))
        else {
            return;
        };
        if *state & PROBED != 0 {
            return;
        }
        *state |= PROBED;
        let n = (ut[1] - ut[0]).cross(ut[2] - ut[0]);
        // Seen from behind: in the expanded triangle's sheet, as that triangle was; in another
        // sheet seen before, as that sheet was; otherwise by the winding convention.
        let back = match (self.neighbours.sheets().of(u), t_sheet) {
            (Some((s, f)), Some((ts, tf))) if s == ts => t_back != (f != tf),
            (Some((s, f)), _) => match self.sheet_side.get(s as usize) {
                Some(&SEEN_FRONT) => f,
                Some(&SEEN_BACK) => !f,
                _ => false,
            },
            (None, _) => false,
        };
        let n = if back { -n } else { n };
        let centre = (ut[0] + ut[1] + ut[2]) / 3.0;
        let corners = self.cell.corners();
        let side = corners.map(|c| n.dot(c - ut[0]));
        let (mut kmax, mut kmin) = (0, 0);
        for k in 1..8 {
            if side[k] > side[kmax] {
                kmax = k;
            }
            if side[k] < side[kmin] {
                kmin = k;
            }
        }
        // In front: the corner furthest in front, the cell's centre and the three corners next
        // to the first, then the other four corners (those in front too), until one sees it: a
        // ray at its centre from each, then (from the first five) rays near its corners.
        let centre_cell = self.cell.centre();
        let order = [kmax, 8, kmax ^ 1, kmax ^ 2, kmax ^ 4, kmax ^ 3, kmax ^ 5, kmax ^ 6, kmax ^ 7];
        for (i, c) in order.map(|k| corners.get(k).copied().unwrap_or(centre_cell)).into_iter().enumerate() {
            if n.dot(c - ut[0]) <= 0.0 || self.has(u) || self.out_of_rays() {
                continue;
            }
            let s = self.handle(c, centre - c, Class::Probe);
            if i >= PROBE_FULL {
                continue;
            }
            // A triangle partly hidden from `c` may show a corner: aim near each (a tenth of the
            // way to the centre, inside the triangle). A corner ray that crosses the triangle which
            // hid the centre from `c` would end on it or nearer, never on `u`, and is not cast (a
            // new triangle nearer than it is left to the other rays).
            let hider = if s.tri != u && s.t < 1.0 { self.tris.get(s.tri as usize) } else { None };
            for v in ut {
                if self.has(u) || self.out_of_rays() {
                    break;
                }
                let d = v + (centre - v) * PROBE_INSET - c;
                if hider.is_some_and(|x| intersect_brute(std::slice::from_ref(x), c, d, 1.0).is_some()) {
                    continue;
                }
                self.handle(c, d, Class::Probe);
            }
        }
        let c = corners[kmin];
        if n.dot(c - ut[0]) < 0.0 && !self.has(u) && !self.out_of_rays() {
            self.handle(c, centre - c, Class::Probe);
        }
        // Last, rays from random points of the cell in front of it at random points of it (none
        // when the whole cell is behind it).
        let (mut cast, mut drawn) = (0, 0);
        let budget = if side[kmax] > 0.0 { PROBE_TRIES * self.p.probe_rays } else { 0 };
        while cast < self.p.probe_rays && drawn < budget {
            if self.has(u) || self.out_of_rays() {
                break;
            }
            drawn += 1;
            let (o, aim) = self.cell.segment_to(ut, self.probe_seq.next_point());
            if n.dot(o - ut[0]) <= 0.0 {
                continue;
            }
            self.handle(o, aim - o, Class::Probe);
            cast += 1;
        }
    }

    /// Corner re-seeding (this project's extension, "sil"): an outline point whose ray escaped or
    /// hit much farther than aimed lies past a silhouette of the seed's surface, and one whose ray
    /// hit much nearer lies behind an occluder. What hides there is best seen from the cell corner
    /// furthest out past the silhouette (or away from the occluder). From that corner, cast at the
    /// triangle's centre (when it hits the triangle, queue it as a seed from there, so ABS runs
    /// again from the new origin) and at the outline point. Each (triangle, corner) pair is tried
    /// once.
    fn reseed_silhouette(&mut self, seed: Seed, tri: &[Vec3; 3], pts: &[Vec3; 9], samples: &[Sample; 9]) {
        let o = seed.origin;
        let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
        let view = centre - o;
        let mut corners = 0u8;
        let mut aim = [Vec3::ZERO; 8];
        for (p, s) in pts.iter().zip(samples) {
            let aimed = (*p - o).length();
            let dist = (s.pos - o).length();
            let out = if s.tri == NONE || dist > aimed * (1.0 + self.p.disc) {
                // Past a silhouette of the seed's surface: move out past it.
                (*p - centre).reject_from(view)
            } else if dist < aimed * (1.0 - self.p.disc)
                && let Some(near) = self.tris.get(s.tri as usize)
            {
                // Behind an occluder: move away from the occluder to look around it.
                (*p - (near[0] + near[1] + near[2]) / 3.0).reject_from(view)
            } else {
                continue;
            };
            let k = u8::from(out.x > 0.0) | u8::from(out.y > 0.0) << 1 | u8::from(out.z > 0.0) << 2;
            if corners & (1 << k) == 0 {
                aim[k as usize] = *p;
            }
            corners |= 1 << k;
        }
        let Some(tried) = self.tried.get_mut(seed.tri as usize) else {
            return;
        };
        let todo = corners & !*tried;
        *tried |= corners;
        for k in 0..8u8 {
            if todo & (1 << k) == 0 || self.out_of_rays() {
                continue;
            }
            let pick =
                |bit: u8, axis: usize| if k & bit != 0 { self.cell.max[axis] } else { self.cell.min[axis] };
            let corner = Vec3::new(pick(1, 0), pick(2, 1), pick(4, 2));
            if (corner - o).length_squared() == 0.0 {
                continue;
            }
            let s = self.cast(corner, centre - corner, Class::Silhouette);
            if s.tri == seed.tri {
                self.queue.push_back(Seed { origin: corner, tri: seed.tri, hit: s.pos });
            } else if s.tri != NONE && self.insert(s.tri, corner, s.pos) {
                self.queue.push_back(Seed { origin: corner, tri: s.tri, hit: s.pos });
            }
            // And at the outline point that was hidden or past the silhouette from `o`.
            let p = aim[k as usize];
            self.handle(corner, p - corner, Class::Silhouette);
        }
    }

    /// Cast an edge ray at `p`, handle it and check it for a discontinuity.
    fn edge_ray(&mut self, o: Vec3, p: Vec3, e2: Vec3) -> Sample {
        let s = self.handle(o, p - o, Class::Edge);
        self.check_discontinuity(o, p, s, e2);
        s
    }

    /// Stock recursive subdivision of the outline edge `a`–`b`.
    #[allow(clippy::too_many_arguments)]
    fn bisect(&mut self, o: Vec3, a: Vec3, sa: Sample, b: Vec3, sb: Sample, depth: u32, e2: Vec3) {
        if sa.tri == sb.tri || depth >= self.p.max_depth || self.out_of_rays() {
            return;
        }
        let m = (a + b) * 0.5;
        if let Some(adt) = self.p.adt
            && (a - b).length() < adt * (m - o).length()
        {
            return;
        }
        let sm = self.edge_ray(o, m, e2);
        self.bisect(o, a, sa, m, sm, depth + 1, e2);
        self.bisect(o, m, sm, b, sb, depth + 1, e2);
    }

    /// The edge-point walk over the outline edge `a`–`b` (thesis `process_edge`).
    pub(super) fn walk_edge(&mut self, o: Vec3, a: Vec3, sa: Sample, b: Vec3, sb: Sample, e2: Vec3) {
        if sa.tri == sb.tri {
            return;
        }
        if self.p.midpoint {
            let m = (a + b) * 0.5;
            let sm = self.edge_ray(o, m, e2);
            let mut steps = 0;
            self.walk(o, a, sa, m, sm, e2, &mut steps, 0);
            let mut steps = 0;
            self.walk(o, m, sm, b, sb, e2, &mut steps, 0);
        } else {
            let mut steps = 0;
            self.walk(o, a, sa, b, sb, e2, &mut steps, 0);
        }
    }

    /// One segment of the walk: step from `a` past the far boundary of its object, or from `b` past
    /// the near boundary of its object, or (both ends escaped, or no boundary found) bisect.
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &mut self,
        o: Vec3,
        a: Vec3,
        sa: Sample,
        b: Vec3,
        sb: Sample,
        e2: Vec3,
        steps: &mut u32,
        depth: u32,
    ) {
        if sa.tri == sb.tri || *steps >= WALK_STEPS || depth >= self.p.max_depth || self.out_of_rays() {
            return;
        }
        *steps += 1;
        let len = (b - a).length();
        // Nothing narrower than the enlargement offset is resolved.
        let eps = self.p.eps;
        if len.is_nan() || len <= eps * ((a + b) * 0.5 - o).length() {
            return;
        }
        // Step past a boundary by a twentieth of the enlargement offset (at most a quarter of the
        // segment), in units of the segment.
        let push = |x: Vec3| (0.05 * eps * (x - o).length()).min(0.25 * len) / len;
        let fan = Fan::new(o, a, b);
        if let Some(tri) = self.tris.get(sa.tri as usize)
            && let Some([_, (s, x)]) = fan.span(tri)
        {
            let s = s + push(x);
            if s > 0.0 && s < 1.0 {
                let m = a + (b - a) * s;
                let sm = self.edge_ray(o, m, e2);
                if sm.tri != sa.tri {
                    self.walk(o, m, sm, b, sb, e2, steps, depth);
                    return;
                }
            }
        }
        if let Some(tri) = self.tris.get(sb.tri as usize)
            && let Some([(s, x), _]) = fan.span(tri)
        {
            let s = s - push(x);
            if s > 0.0 && s < 1.0 {
                let m = a + (b - a) * s;
                let sm = self.edge_ray(o, m, e2);
                if sm.tri != sb.tri {
                    self.walk(o, a, sa, m, sm, e2, steps, depth);
                    return;
                }
            }
        }
        let m = (a + b) * 0.5;
        let sm = self.edge_ray(o, m, e2);
        self.walk(o, a, sa, m, sm, e2, steps, depth + 1);
        self.walk(o, m, sm, b, sb, e2, steps, depth + 1);
    }

    /// `check_discontinuity`: the ray `o + t (p - o)` hit `s`; when that is much nearer than `p`
    /// (`t < 1 - disc`: the hit is nearer by more than `disc` of the aimed distance), count it and
    /// (when enabled) reverse-sample into the gap behind the occluder. `e2` is a point known
    /// visible on the far surface (the seed's hit point).
    pub(super) fn check_discontinuity(&mut self, o: Vec3, p: Vec3, s: Sample, e2: Vec3) {
        if s.tri == NONE || 1.0 - s.t <= self.p.disc {
            return;
        }
        self.stats.discontinuities += 1;
        if self.p.reverse && !self.out_of_rays() {
            self.reverse(o, p, e2, s.tri);
        }
    }

    /// Reverse sampling: the occluder `near` hides the aimed point `e1` from `o`; find the point of
    /// its boundary in the plane (o, e1, e2) on the side of `e2`, push it just outside, and shoot
    /// from where the line e1 → that point leaves through the cell back at `e1`.
    fn reverse(&mut self, o: Vec3, e1: Vec3, e2: Vec3, near: u32) {
        let Some(tri) = self.tris.get(near as usize) else {
            return;
        };
        let Some([_, (s, x)]) = Fan::new(o, e1, e2).span(tri) else {
            return;
        };
        if s <= 0.0 {
            return;
        }
        let view = x - o;
        let side = (e2 - e1).reject_from(view).normalize_or_zero();
        let x = x + side * (self.p.eps * view.length());
        let d = x - e1;
        let Some((l0, _)) = self.cell.clip(e1, d, 1.0, f32::INFINITY) else {
            return;
        };
        let origin = e1 + d * l0;
        if (origin - e1).length_squared() > 0.0 {
            self.handle(origin, e1 - origin, Class::Reverse);
        }
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

#[cfg(test)]
mod tests {
    use super::{ParamError, Params};

    #[test]
    fn check_accepts_the_defaults_and_every_variant_and_rejects_what_turns_gvs_off() {
        assert_eq!(Params::default().check(), Ok(()));
        for v in super::super::Variant::ALL {
            assert_eq!(v.params(Params::default()).check(), Ok(()), "{}", v.name());
        }
        let with = |f: fn(&mut Params)| {
            let mut p = Params::default();
            f(&mut p);
            p.check()
        };
        assert!(matches!(with(|p| p.eps = f32::NAN), Err(ParamError::Eps(_))));
        assert_eq!(with(|p| p.eps = 0.0), Err(ParamError::Eps(0.0)));
        assert_eq!(with(|p| p.eps = 2.0), Err(ParamError::Eps(2.0)));
        assert_eq!(with(|p| p.eps = 1.0), Ok(()));
        assert!(matches!(with(|p| p.disc = f32::NAN), Err(ParamError::Disc(_))));
        assert_eq!(with(|p| p.disc = -0.1), Err(ParamError::Disc(-0.1)));
        assert_eq!(with(|p| p.disc = 1.0), Err(ParamError::Disc(1.0)));
        assert_eq!(with(|p| p.disc = 0.0), Ok(()));
        assert_eq!(with(|p| p.adt = Some(f32::INFINITY)), Err(ParamError::Adt(f32::INFINITY)));
        assert_eq!(with(|p| p.adt = Some(0.0)), Err(ParamError::Adt(0.0)));
        assert_eq!(with(|p| p.adt = Some(1e-4)), Ok(()));
    }
}
