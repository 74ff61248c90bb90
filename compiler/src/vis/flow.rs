//! Full vis: depth-first flow from one one-way portal (the source) through the clusters in front
//! of it.
//!
//! A stack frame holds the cluster reached, the (clipped) source and pass windings and the portals
//! still possibly visible (`might`). For every portal `p` (the target) leaving the cluster:
//! `might` narrows to what `p` itself might see (its `mightsee`, or its final row once `p` is
//! done). Pruning works on clusters, since the PVS is about clusters: the flow keeps the set of
//! clusters seen so far and the portals leading into them ("covered"); a branch dies when `p`
//! leads to a seen cluster and `might` holds no uncovered portal, and when only `p`'s own cluster
//! is new, `p` is tested but not entered. A tested target is clipped to the front of the source
//! portal and of the pass portal, the source to the back of `p`, and then, by level: 1 the target
//! by separators (source edge, pass vertex); 2 also (pass edge, source vertex); 3 the source by
//! separators (target edge, pass vertex); 4 also (pass edge, target vertex). Separators of an
//! unchanged (source, pass) pair are computed once per frame and reused for every target of the
//! frame; tests 3 and 4 run only when the frame below has a target to test. A clip that a line
//! test shows would keep its winding whole is skipped ([`Sight`]). All clips round toward visible
//! (see [`super::poly`]). Before a target's winding is even copied, its bounding sphere meets the
//! frame's first separators, one dot product a plane: of the 36.8 M targets the separators kill
//! on the generated `arena_32`, 32.1 M die there. Windings that clips have grown past
//! [`SIMPLIFY_ABOVE`] points are simplified, which keeps more.
//!
//! Beam culling: on entering a frame that still has uncovered portals in `might`, those lying
//! wholly behind one of the frame's separators (or its pass plane) are dropped from `might`, so a
//! branch dies as soon as nothing it could still reach is new. On E1M1 this cuts the chains
//! visited from 4.0 M to 0.93 M. Where `mightsee` is already tight (an open room, a ring of
//! leaves round a pillar) the cull drops nothing and is pure cost: a flow whose first culls (its
//! `trial`, [`BEAM_TRIAL`], or [`QUIET_TRIAL`] once the last [`QUIET_FLOWS`] flows folded dropped
//! nothing, see [`trial_after`]) have dropped nothing culls no more. The cull only prunes, so
//! skipping it keeps as much or more, and the trial depends on the batches folded before the
//! flow only, so the result does not depend on threads.
//!
//! Rows: a frame lists its open words, those of `might` holding a portal not yet covered; they
//! are a subset of the frame below's (`might` only narrows along a chain, `vis` only grows), so
//! finding them, testing whether a target leads to anything new and the beam cull read those few
//! words rather than the whole row; and a frame's row is built only once its target passed every
//! clip. On a room of 125 tiny brushes (every leaf sees every leaf, a row spans 66 words of which
//! about 3 are open) this cuts vis's instructions by 8 % for the same chains and PVS. A frame
//! with at most [`FEW_UNCOVERED`] portals not yet covered asks whether a target leads to one of
//! them through their reversed rows, which stay in cache from target to target, instead of
//! through the target's own row, and the target's cluster is read from [`Graph::leaves`]: on the
//! 10,000-brush room merged into 73 clusters (a frame scans about 1,200 targets, each row and
//! [`OneWay`](super::graph::OneWay) a cache miss), the flow took 14.1–15.3 s instead of
//! 16.5–23.3 s in alternating runs, with the same chains and PVS.
//!
//! Seeds: some clusters count as seen from the start: those a certified line ([`super::certify`])
//! reaches through the source portal, and those the finished flows of its cluster's other
//! portals counted seen. A flow records both for later flows ([`super::seeds`]): for every
//! portal its new certified lines cross, the clusters they reach beyond it, and, when it ends,
//! the clusters it saw as seen from its own cluster (which that cluster's row holds anyway).
//! A frame remembers how many of the chain's clusters already have all their pairs recorded, so a
//! line certified one frame deeper records only the pairs of the clusters after those: along a
//! straight corridor, a number of pairs growing with the depth rather than with its square.
//! When the seeds are most of the clusters, a flow covers every portal and uncovers those into
//! the others, rather than covering the seeded clusters' portals one by one: on the
//! 10,000-brush room merged into 73 clusters, 87,010 bits a flow, and 11 % of the flow's time.
//!
//! Explored frames: a flow keeps the frames it has explored ([`Explored`]), and a frame whose
//! source, pass and `might` lie inside those of one kept for the same portal is not explored
//! again: its lines are a subset of that frame's, which found everything they reach. On the
//! generated terrain and city maps a flow enters most portals more than once, along different
//! routes; on ericw-tools' files of them, skipping the covered frames visits 26–52 % fewer chains
//! for the same PVS (the arenas: 0.4–1.1 %).
//!
//! Loops: a chain never enters a cluster it already passed through (one of its frames'). A line
//! that leaves a cluster and comes back into it, as it may into a cluster merged by `coarsen` or
//! by `func_viscluster` (not convex), goes on through some portal `q` out of it; the chain that
//! skips the loop tests `q` from the cluster's first frame, under constraints that are a subset of
//! the loop's (fewer portals to clip by, a `might` narrowed by fewer rows), so it keeps the line.
//! Without this a few merged clusters among many small ones made flows follow every order of the
//! same loops: the generated `arena_32` under an eighth of its work estimate (323 merged clusters)
//! made 99.5 M chains, against 76,044 with it. A kept explored frame is only as good as its chain:
//! one whose exploration skipped a loop back into a cluster before it covers no later frame.
//!
//! Depth: a chain is followed at most [`MAX_FLOW_DEPTH`] frames deep; there every portal still in
//! the frame's `might` counts as seen, which can only keep more. A thread's frames, and the
//! recursion's stack, are bounded by it whatever the input (a straight corridor of `n` leaves
//! would otherwise hold `n` frames of `n`-portal rows, and visit `n²/2` chains from each end);
//! on the shared real maps (id's and LibreQuake's, compiled by ericw-tools) no result changes.
//!
//! The result of a flow is the set of portals it might see that lead into a cluster it sees: a
//! superset of the portals truly visible through the source, so later flows may narrow by it.

use glam::DVec3;
use sightline_formats::geom::Plane;

use super::certify;
use super::explored::{Explored, KEEP_CHAINS};
use super::graph::Graph;
use super::poly::{
    CAP, CLIP_EPSILON, Clip, Poly, Sight, Sphere, TOUCH_EPSILON, clip_to_separators, for_each_separator,
};
use super::seeds::{Recorder, Seeds};
use sightline_formats::bits;

/// Deepest frame a flow enters (its source portal's frame is 0). There the chain stops and every
/// portal it might still see counts as seen, which can only keep more: a thread holds at most this
/// many frames (rows of portal bits) whatever the input. No result on the shared real maps comes
/// near it (they are the same with a limit of 64 and without one).
pub const MAX_FLOW_DEPTH: usize = 64;

/// [`Flow::on_chain`] of a cluster no frame of the chain reached (a depth is at most
/// [`MAX_FLOW_DEPTH`]).
const OFF_CHAIN: u8 = u8::MAX;
const _: () = assert!(MAX_FLOW_DEPTH < OFF_CHAIN as usize);

/// Most portals not yet covered a frame lists to test targets by their reversed rows
/// ([`Frame::leads_on`]): with more, the targets' own rows are read. On the merged 10,000-brush
/// room 32, 128 and 1,024 gave flows within the host's noise of each other; the generated
/// `city_28` is as fast as reading the targets' rows (median ratio 0.99 over five pairs).
pub const FEW_UNCOVERED: usize = 128;

/// Beam culls a flow makes before it gives up culling if none of them dropped a portal. On
/// ericw-tools' pillar rooms this saves 24 % (300 sides) and 43 % (600 sides) of vis's
/// instructions with the same chains and PVS; dm1 and dm2 visit 0.1–0.4 % more chains for the
/// same PVS (8 would save pillar_300 a few % more, at 2 % more chains on dm1).
pub const BEAM_TRIAL: u32 = 16;

/// Flows folded in a row whose culls dropped nothing, after which flows start with the short
/// trial [`QUIET_TRIAL`]: on a ring of leaves round a pillar (ericw-tools' compiles, 300 and 600
/// sides) this saves 13 % and 35 % of vis's instructions; on dm1, dm2 and E1M1 flows drop
/// portals often enough to break every run of 32, and they visit the same chains (dm1 one more
/// of 63,657) for the same PVS.
pub const QUIET_FLOWS: usize = 32;

/// The trial of a flow started after [`QUIET_FLOWS`] quiet flows: a flow whose first culls drop
/// a portal still culls on, and breaks the run for the flows after it.
pub const QUIET_TRIAL: u32 = 2;

/// The beam-cull trial for a flow started after `quiet` folded flows in a row dropped nothing.
pub fn trial_after(quiet: usize) -> u32 {
    if quiet >= QUIET_FLOWS { QUIET_TRIAL } else { BEAM_TRIAL }
}

/// The run of quiet flows once a flow that `dropped` (or not) a portal by a cull is folded after
/// a run of `quiet`.
pub fn quiet_after(quiet: usize, dropped: bool) -> usize {
    if dropped { 0 } else { quiet.saturating_add(1) }
}

/// Clipped windings of the flow with more points than this are simplified ([`Poly::simplify`]):
/// clips add points, and a long chain's windings reach tens of them (on the generated open
/// terrain, up to 70), which every separator then pays for twice (edges by points). On
/// `terrain_32` this saves 10 % of vis's instructions for 0.01 % more visible pairs.
pub const SIMPLIFY_ABOVE: usize = 6;

/// The most area a removed point may add to a simplified winding, as a share of its area.
pub const SIMPLIFY_SHARE: f64 = 0.02;

/// Normals whose dot product is at most `-1 + this` are opposite: a line that entered through one
/// cannot leave through the other.
const OPPOSITE_EPSILON: f64 = 1e-12;

/// The source portal of a flow: its plane (normal forward) and a sphere holding it.
#[derive(Debug, Clone, Copy)]
struct Head {
    plane: Plane,
    bound: Sphere,
}

#[derive(Debug, Clone, Default)]
struct Frame {
    /// The portal that led here (the base portal in frame 0).
    portal: u32,
    /// Cluster reached.
    leaf: u32,
    /// Plane of the portal that led here (normal into `leaf`).
    plane: Option<Plane>,
    source: Poly,
    pass: Poly,
    might: Vec<u64>,
    /// The words of `might` that held a portal not yet covered (in the flow's `vis`) when the
    /// frame was entered; `vis` only grows, so no other word can hold one later.
    open: Vec<usize>,
    /// The portals not yet covered in `might` when the frame was entered, if at most
    /// [`FEW_UNCOVERED`] ([`Frame::leads_on`]); else empty.
    uncovered: Vec<u32>,
    /// Words of `might` outside `lo..hi` are zero (and not stored).
    lo: usize,
    hi: usize,
    /// Separators of (`source`, `pass`): normal order then flipped order, each computed when
    /// first needed (a target gone by the first list never needs the second).
    seps: [Vec<Plane>; 2],
    seps_ready: [bool; 2],
    /// Tests 3 and 4 (narrowing `source`) are still to run.
    narrow: bool,
    /// The first this many clusters of the chain (see [`Flow::certify`]) have every pair among
    /// them recorded as seeds by this flow (or known before it).
    paired: usize,
}

/// A thread's scratch space for clipping, reused from clip to clip.
#[derive(Debug, Default)]
struct Scratch {
    tmp: Poly,
    sight: Sight,
}

/// Per-thread flow state, reused from portal to portal (no allocation once frames exist).
#[derive(Debug)]
pub struct Flow {
    frames: Vec<Frame>,
    scratch: Scratch,
    /// Portals leading into a cluster already known visible from the base portal.
    vis: Vec<u64>,
    /// Clusters known visible from the base portal.
    seen: Vec<u64>,
    words: usize,
    level: u8,
    /// Recursive calls made (portal chains visited).
    pub chains: u64,
    /// Past this many chains the flow unwinds at once: its run is being given up (a merge whose
    /// flow runs over its cap, see `vis::run`), so its row is no result.
    pub chain_limit: u64,
    /// Look for certified sight lines (for seeds).
    seeding: bool,
    /// The one-way portals a certified line crosses and its clusters (see [`Flow::certify`]),
    /// reused from line to line.
    line: Vec<u32>,
    on: Vec<u32>,
    /// Seed pairs recorded and not yet flushed to the shared matrix ([`Seeds::record`]).
    recorded: Recorder,
    /// Frames this flow has explored, which may cover later ones, and the chains a frame's
    /// exploration must have visited to be kept ([`KEEP_CHAINS`]).
    explored: Explored,
    keep_chains: u64,
    /// Per cluster, the depth of the chain's frame that reached it, or [`OFF_CHAIN`].
    on_chain: Vec<u8>,
    /// The shallowest depth a skipped loop (see the module docs) went back to since this was last
    /// reset: a frame whose exploration skipped a loop into a cluster before it is not kept.
    loop_depth: usize,
    /// Beam culls made by this flow so far, and whether any of them dropped a portal.
    culls: u32,
    culled: bool,
    /// Culls the flow makes before it stops if none of them dropped a portal.
    beam_trial: u32,
}

impl Flow {
    /// State for `portals` one-way portals, `clusters` clusters and separator `level` 0..=4;
    /// `seeding` looks for certified sight lines.
    pub fn new(portals: usize, clusters: usize, level: u8, seeding: bool) -> Self {
        let words = bits::words(portals);
        Self {
            frames: Vec::new(),
            scratch: Scratch::default(),
            vis: vec![0; words],
            seen: vec![0; bits::words(clusters)],
            words,
            level,
            chains: 0,
            chain_limit: u64::MAX,
            seeding,
            line: Vec::new(),
            on: Vec::new(),
            recorded: Recorder::new(portals, clusters),
            explored: Explored::new(portals),
            keep_chains: KEEP_CHAINS,
            on_chain: vec![OFF_CHAIN; clusters],
            loop_depth: usize::MAX,
            culls: 0,
            culled: false,
            beam_trial: BEAM_TRIAL,
        }
    }

    /// An upper bound of the bytes a flow's state takes for `portals` one-way portals and
    /// `clusters` clusters: its frames at the deepest, its rows, a certified line's portals
    /// (the chain's, and up to [`MAX_FLOW_DEPTH`] each way beyond it) and its [`Recorder`].
    pub fn bytes(portals: usize, clusters: usize) -> u128 {
        let words = bits::words(portals);
        let frame = std::mem::size_of::<Frame>() + 16 * words + 2 * CAP * std::mem::size_of::<Plane>();
        (MAX_FLOW_DEPTH as u128 + 1) * frame as u128
            + std::mem::size_of::<Self>() as u128
            + 8 * (words + bits::words(clusters)) as u128
            + clusters as u128
            + 8 * (3 * MAX_FLOW_DEPTH as u128 + 2)
            + Recorder::bytes(portals, clusters)
            + Explored::bytes(portals)
    }

    /// Whether a beam cull of the last [`Flow::run`] dropped a portal.
    pub fn dropped(&self) -> bool {
        self.culled
    }

    /// Cluster `c` is visible: every portal into it is covered.
    fn see(&mut self, g: &Graph, c: u32) {
        see(&mut self.seen, &mut self.vis, g, c);
    }

    fn frame(&mut self, d: usize) {
        while self.frames.len() <= d {
            self.frames.push(Frame {
                might: vec![0; self.words],
                open: Vec::with_capacity(self.words),
                uncovered: Vec::with_capacity(FEW_UNCOVERED),
                ..Frame::default()
            });
        }
    }

    /// The portals visible through portal `base`; `test` holds per portal its final vis when done,
    /// else its `mightsee` (`words` words per portal), its rows kept in consistent pairs
    /// ([`super::symmetry`]: every caller tightens them so and replaces rows only through
    /// `symmetry::replace_row`), which [`Frame::leads_on`] relies on. Writes the result into
    /// `out`; the flow makes `trial` beam culls before it stops culling if none of them dropped a
    /// portal (see [`Flow::dropped`]).
    ///
    /// The clusters `seeds` knows visible through `base`, or seen by earlier flows from the
    /// cluster `base` leaves, are marked seen from the start, so branches that could only find
    /// them are not explored. The row stays a superset of what `base` sees (it may also hold
    /// portals into clusters seen only through the cluster's other portals, which the cluster's
    /// row holds anyway). The seeds the run certifies are recorded in `seeds`.
    pub fn run(&mut self, g: &Graph, test: &[u64], seeds: &Seeds, base: usize, trial: u32, out: &mut [u64]) {
        self.explored.clear();
        self.culls = 0;
        self.culled = false;
        self.beam_trial = trial;
        self.loop_depth = usize::MAX;
        let p = &g.portals[base];
        let (through, of_cluster) =
            (seeds.row(seeds.through(base as u32) as usize), seeds.row(seeds.of_cluster(p.owner) as usize));
        see_seeds(&mut self.seen, &mut self.vis, g, through, of_cluster);
        self.see(g, p.leaf);
        self.see(g, p.owner);
        self.frame(0);
        let f = &mut self.frames[0];
        f.portal = base as u32;
        f.leaf = p.leaf;
        f.plane = Some(p.plane);
        f.source.load(g.winding(p), p.plane.normal);
        f.pass.n = 0;
        f.might.copy_from_slice(&test[base * self.words..(base + 1) * self.words]);
        f.lo = f.might.iter().position(|&w| w != 0).unwrap_or(0);
        f.hi = f.might.iter().rposition(|&w| w != 0).map_or(0, |w| w + 1);
        f.seps_ready = [false; 2];
        f.narrow = false;
        f.paired = 1;
        let head = Head { plane: p.plane, bound: Sphere { center: p.center, radius: p.radius } };
        self.on_chain[p.leaf as usize] = 0;
        self.recurse(g, test, seeds, 0, &head);
        self.on_chain[p.leaf as usize] = OFF_CHAIN;
        if self.seeding {
            // Every cluster counted seen is in the PVS of the base portal's cluster (the row
            // below holds a portal into it), so later flows from that cluster's other portals may
            // start with it seen.
            seeds.record_row(seeds.of_cluster(p.owner), &self.seen);
        }
        seeds.flush(&mut self.recorded);
        // Portals it might see that lead into a cluster it sees: a superset of the portals it
        // sees, which is what later flows may narrow by.
        let might = &test[base * self.words..(base + 1) * self.words];
        for ((o, &v), &m) in out.iter_mut().zip(&self.vis).zip(might) {
            *o = v & m;
        }
    }

    fn recurse(&mut self, g: &Graph, test: &[u64], seeds: &Seeds, d: usize, head: &Head) {
        self.chains += 1;
        if self.chains > self.chain_limit {
            return;
        }
        let words = self.words;
        let leaf = self.frames[d].leaf as usize;
        // Without a target worth testing (one still possibly visible that leads to an unseen
        // cluster or beyond which something unseen might lie) the branch ends here, before the
        // frame's separators are built. The loop below skips the same targets.
        let Self { frames, seen, vis, .. } = self;
        // A word open here was open in the frame below: `might` only narrows along the chain and
        // `vis` only grows, so only the words of that frame's list need a look.
        let (below, rest) = frames.split_at_mut(d);
        let here = &mut rest[0];
        let mut open = std::mem::take(&mut here.open);
        open.clear();
        match below.last() {
            Some(b) => open.extend(b.open.iter().copied().filter(|&w| here.might[w] & !vis[w] != 0)),
            None => open.extend((here.lo..here.hi).filter(|&w| here.might[w] & !vis[w] != 0)),
        }
        here.open = open;
        here.list_uncovered(vis);
        let here = &frames[d];
        // The targets before the first worth testing stay unworthy (`might` only narrows, `vis`
        // and `seen` only grow): the loop below starts at it.
        let Some(first) = g.cluster_portals[leaf].iter().position(|&pi| {
            let pi = pi as usize;
            here.may_see(pi) && here.worth(g, test, pi, seen, vis)
        }) else {
            return;
        };
        if d == MAX_FLOW_DEPTH {
            // Too deep to follow: whatever the branch might still reach counts as seen.
            let Self { frames, seen, vis, .. } = self;
            let f = &frames[d];
            for w in f.lo..f.hi {
                for q in bits::word_ones(w, f.might[w]) {
                    see(seen, vis, g, g.portals[q].leaf);
                }
            }
            return;
        }
        self.frame(d + 1);
        if d > 0 && self.level > 0 && !self.cull_beyond_beam(g, d, head) {
            return;
        }
        for &pi in &g.cluster_portals[leaf][first..] {
            let pi = pi as usize;
            if !self.frames[d].may_see(pi) {
                continue;
            }
            let (lo, hi) = self.frames.split_at_mut(d + 1);
            let (prev, next) = (&mut lo[d], &mut hi[0]);
            let trow = &test[pi * words..(pi + 1) * words];
            // Worth testing: into an unseen cluster, or with a portal not yet covered beyond it
            // (`Frame::worth`). Into an unseen cluster, whether anything lies beyond is asked only
            // once `p` has passed every test (reading `p`'s row is a cache miss on big maps, and
            // most such targets die first), still before `p` covers its own portals.
            let unseen = !bits::get(&self.seen, g.leaves[pi] as usize);
            if !unseen && !prev.leads_on(test, pi, &self.vis) {
                continue;
            }
            let p = &g.portals[pi];
            // Tests 3 and 4 already narrowed `prev.source` in `cull_beyond_beam`: a frame gets
            // here only with a target worth testing, so with something new in `might`.
            debug_assert!(!prev.narrow);
            let Some(prev_plane) = prev.plane else { continue };
            if p.plane.normal.dot(prev_plane.normal) <= -1.0 + OPPOSITE_EPSILON {
                continue; // straight back out through the way in
            }
            let target = Sphere { center: p.center, radius: p.radius };
            if d > 0 && self.level > 0 {
                // Most targets that die lie wholly behind a separator of the frame's (source,
                // pass) by their sphere: one dot product per plane, before any winding is
                // copied. A source cut below only narrows the beam, so this holds then too.
                prev.ensure_separators(0, g.convex);
                if prev.seps[0].iter().any(|plane| target.behind(plane)) {
                    continue;
                }
            }
            // Target: in front of the source portal (quick sphere test first).
            let tmp = &mut self.scratch.tmp;
            next.pass.load(g.winding(p), p.plane.normal);
            if next.pass.clip_in(&target, &head.plane, CLIP_EPSILON, tmp) == Clip::Gone {
                continue;
            }
            // Source: behind the target.
            next.source.copy_from(&prev.source);
            let back = p.plane.flipped();
            let source_clip = next.source.clip_in(&head.bound, &back, CLIP_EPSILON, tmp);
            if source_clip == Clip::Gone {
                continue;
            }
            next.portal = pi as u32;
            next.leaf = p.leaf;
            next.plane = Some(p.plane);
            next.seps_ready = [false; 2];
            next.narrow = false;
            next.paired = prev.paired;
            if d > 0 {
                // Target: in front of the pass portal.
                if next.pass.clip_in(&target, &prev_plane, CLIP_EPSILON, tmp) == Clip::Gone {
                    continue;
                }
                if !clip_target(self.level, g.convex, prev, next, source_clip, &target, &mut self.scratch) {
                    continue;
                }
                next.pass.simplify(SIMPLIFY_ABOVE, SIMPLIFY_SHARE, &target);
                // Tests 3 and 4 narrow the source for the frame below: deferred until that frame
                // has a target worth testing (see `narrow_source`).
                next.narrow = self.level > 2;
            }
            let deeper = !unseen || self.frames[d].leads_on(test, pi, &self.vis);
            if unseen {
                self.see(g, p.leaf);
                if self.seeding {
                    self.certify(g, seeds, d + 1);
                }
            }
            if deeper && self.on_chain[p.leaf as usize] != OFF_CHAIN {
                // A loop back into a cluster of the chain: the chain from that cluster's frame
                // tests whatever it goes on to (see the module docs).
                self.loop_depth = self.loop_depth.min(usize::from(self.on_chain[p.leaf as usize]));
            } else if deeper {
                // The row of the frame beyond `p`, built only once `p` passed every test.
                let (lo, hi) = self.frames.split_at_mut(d + 1);
                narrow_row(&lo[d], &mut hi[0], trow);
                // Unless a frame explored before covers it ([`Explored`]): the source is checked
                // before tests 3 and 4 narrow it, which only makes it harder to cover.
                let next = &self.frames[d + 1];
                if self.explored.covers(pi, &next.source, &next.pass, &next.might, next.lo, next.hi) {
                    continue;
                }
                let (chains, outer_loops) = (self.chains, self.loop_depth);
                self.loop_depth = usize::MAX;
                // `d + 1` is at most `MAX_FLOW_DEPTH`, below `OFF_CHAIN`.
                self.on_chain[p.leaf as usize] = (d + 1) as u8;
                self.recurse(g, test, seeds, d + 1, head);
                self.on_chain[p.leaf as usize] = OFF_CHAIN;
                let inner_loops = self.loop_depth;
                self.loop_depth = outer_loops.min(inner_loops);
                if self.chains > self.chain_limit {
                    return;
                }
                // Kept only if no loop it skipped went back before it: a frame of the same portal
                // reached by another chain would have followed such a loop.
                if self.chains - chains >= self.keep_chains && inner_loops > d {
                    let next = &self.frames[d + 1];
                    self.explored.keep(pi, &next.source, &next.pass, &next.might, next.lo, next.hi);
                }
            }
        }
    }
}

impl Flow {
    /// Frame `k` was just reached through a new cluster: if the line from the middle of its
    /// clipped source to the middle of its clipped target, or one through the middle of the
    /// first or last clipped pass portal, crosses every original winding of the chain (frames
    /// `1..k`), record seeds: every two clusters the line runs through see each
    /// other. Those are the chain's clusters (the base portal's owner, then the cluster each
    /// frame `0..=k` reached) and those the line runs on into past the target and behind the
    /// source ([`certify::walk`]); the ones past the target are seen by this flow as well.
    /// Pairs among the first [`Frame::paired`] clusters of the chain are already recorded; the
    /// frame's chain is then fully paired.
    fn certify(&mut self, g: &Graph, seeds: &Seeds, k: usize) {
        let chain = &self.frames[..=k];
        let base = &g.portals[chain[0].portal as usize];
        let target = &g.portals[chain[k].portal as usize];
        let (Some(a), Some(b)) = (
            certify::centroid(&chain[k].source.p[..chain[k].source.n]),
            certify::centroid(&chain[k].pass.p[..chain[k].pass.n]),
        ) else {
            return;
        };
        let certified = |a: DVec3, b: DVec3| {
            base.plane.distance(b) > certify::CERTIFY_MARGIN
                && target.plane.distance(a) < -certify::CERTIFY_MARGIN
                && certify::inside(g.edges(base), a)
                && certify::inside(g.edges(target), b)
                && certify::crosses(
                    a,
                    b,
                    chain[1..k].iter().map(|f| {
                        let p = &g.portals[f.portal as usize];
                        (&p.plane, g.edges(p))
                    }),
                )
        };
        // Then lines through the middle of the last and of the first clipped pass portal, from
        // the source's middle on to the target's plane, and from the target's middle back to the
        // source's plane: where openings are offset, the middles' line misses one of them.
        let through = |j: usize| certify::centroid(&chain[j].pass.p[..chain[j].pass.n]);
        let passes: &[usize] = match k {
            0 | 1 => &[],
            2 => &[1],
            _ => &[k - 1, 1],
        };
        let line = if certified(a, b) {
            Some((a, b))
        } else {
            passes.iter().filter_map(|&j| through(j)).find_map(|m| {
                let ahead = certify::extend(a, m, &target.plane).filter(|&b2| certified(a, b2));
                ahead.map(|b2| (a, b2)).or_else(|| {
                    certify::extend(b, m, &base.plane).filter(|&a2| certified(a2, b)).map(|a2| (a2, b))
                })
            })
        };
        let Some((a, b)) = line else {
            return;
        };
        // The line's one-way portals in its order, each leading from a cluster into the next:
        // those behind the source (walked backwards, so reversed and turned round), the chain's
        // (the base portal, then the one into each frame `1..=k`), and those beyond the target.
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        certify::walk(g, b, a, base.owner, MAX_FLOW_DEPTH, &mut line);
        line.reverse();
        for q in &mut line {
            *q ^= 1;
        }
        let behind = line.len();
        line.extend(chain.iter().map(|f| f.portal));
        let chain_end = line.len();
        certify::walk(g, a, b, target.leaf, MAX_FLOW_DEPTH, &mut line);
        // Its clusters: the first portal's owner, then each portal's leaf. Cluster `i` sees
        // cluster `j > i` through portal `i`, and `j` sees `i` through the reverse of portal
        // `j - 1`. Pairs among the chain's first `paired` clusters (those of the line from
        // `behind` on) are already recorded.
        let mut on = std::mem::take(&mut self.on);
        on.clear();
        on.extend(line.first().map(|&q| g.portals[q as usize].owner));
        on.extend(line.iter().map(|&q| g.portals[q as usize].leaf));
        let paired = behind + chain[k].paired;
        for j in 1..on.len() {
            let back = seeds.through(line[j - 1] ^ 1);
            for i in (0..j).filter(|&i| i < behind || j >= paired) {
                seeds.record(&mut self.recorded, seeds.through(line[i]), on[j]);
                seeds.record(&mut self.recorded, back, on[i]);
            }
        }
        self.frames[k].paired = chain_end - behind + 1;
        // Beyond the target the line runs on through the base portal: seen from here too.
        for &c in &on[chain_end + 1..] {
            see(&mut self.seen, &mut self.vis, g, c);
        }
        self.line = line;
        self.on = on;
    }

    /// Drop from frame `d`'s `might` every portal not yet covered that lies wholly behind (or at
    /// most touching) one of the frame's separators or the plane of its pass portal: every line
    /// through the source and the pass lies in front of those planes beyond the pass, so no line
    /// of this branch reaches it. Only uncovered portals keep a branch alive, so testing those is
    /// enough for pruning. Once the flow's first [`BEAM_TRIAL`] culls have dropped nothing, only
    /// the source is narrowed. Returns `false` when no source is left.
    fn cull_beyond_beam(&mut self, g: &Graph, d: usize, head: &Head) -> bool {
        // The frame's open words ([`Frame::open`], found on entering it, `vis` unchanged since)
        // are the words holding a portal not yet covered.
        if self.frames[d].open.is_empty() {
            return true;
        }
        if self.frames[d].narrow {
            self.frames[d].narrow = false;
            let frames = &mut self.frames[..=d];
            if !narrow_source(self.level, g.convex, frames, head, &mut self.scratch) {
                return false;
            }
            self.frames[d].source.simplify(SIMPLIFY_ABOVE, SIMPLIFY_SHARE, &head.bound);
        }
        if self.culls >= self.beam_trial && !self.culled {
            return true;
        }
        self.culls += 1;
        let f = &mut self.frames[d];
        // The pass plane and the first list, then the flipped list for the portals left: it is
        // built only when some are.
        f.ensure_separators(0, g.convex);
        let mut dropped = false;
        let mut left = false;
        for &w in &f.open {
            for ti in bits::word_ones(w, f.might[w] & !self.vis[w]) {
                let behind = beyond(g, ti);
                if f.plane.as_ref().is_some_and(&behind) || f.seps[0].iter().any(&behind) {
                    f.might[w] &= !bits::mask(ti);
                    dropped = true;
                } else {
                    left = true;
                }
            }
        }
        if left && self.level >= 2 {
            f.ensure_separators(1, g.convex);
            for &w in &f.open {
                for ti in bits::word_ones(w, f.might[w] & !self.vis[w]) {
                    if f.seps[1].iter().any(beyond(g, ti)) {
                        f.might[w] &= !bits::mask(ti);
                        dropped = true;
                    }
                }
            }
        }
        self.culled |= dropped;
        true
    }
}

/// A test that portal `ti` lies wholly behind a plane (or at most touches it), by its sphere and
/// then, when the sphere's centre is behind, by its points.
#[inline]
fn beyond(g: &Graph, ti: usize) -> impl Fn(&Plane) -> bool + '_ {
    let [x, y, z, radius] = g.spheres[ti];
    let sphere = Sphere { center: DVec3::new(x, y, z), radius };
    move |pl: &Plane| {
        sphere.behind(pl)
            || (pl.distance(sphere.center) < 0.0
                && g.winding(&g.portals[ti]).iter().all(|q| pl.distance(*q) <= TOUCH_EPSILON))
    }
}

/// `next`'s `might`: `prev`'s narrowed by `trow` (the row of the portal that leads to `next`),
/// with its bounds of nonzero words.
fn narrow_row(prev: &Frame, next: &mut Frame, trow: &[u64]) {
    let (mut first, mut last) = (prev.hi, prev.lo);
    let range = prev.lo..prev.hi;
    let words_in =
        next.might[range.clone()].iter_mut().zip(&prev.might[range.clone()]).zip(&trow[range.clone()]);
    for (w, ((m, &a), &b)) in range.zip(words_in) {
        *m = a & b;
        if *m != 0 {
            first = first.min(w);
            last = w + 1;
        }
    }
    (next.lo, next.hi) = if first < last { (first, last) } else { (0, 0) };
}

/// Cluster `c` is visible: marked in `seen`, and every portal into it covered in `vis`.
fn see(seen: &mut [u64], vis: &mut [u64], g: &Graph, c: u32) {
    if bits::get(seen, c as usize) {
        return;
    }
    bits::set(seen, c as usize);
    for &q in &g.cluster_incoming[c as usize] {
        bits::set(vis, q as usize);
    }
}

/// Start `seen` and `vis` (whatever they held) from the clusters of `through | of_cluster` (rows
/// of cluster bits), as [`see`] of each would on empty rows. When they are most of the clusters,
/// every portal is covered, then the portals into the clusters not seen are uncovered: each
/// one-way portal leads into exactly one cluster, so `vis` is the same, and on a map merged into
/// a few clusters, where earlier flows saw nearly all of them, a flow sets a row's words instead
/// of tens of thousands of bits one by one.
fn see_seeds(seen: &mut [u64], vis: &mut [u64], g: &Graph, through: &[u64], of_cluster: &[u64]) {
    let (n, nc) = (g.portals.len(), g.num_clusters());
    for (w, (s, (&a, &b))) in seen.iter_mut().zip(through.iter().zip(of_cluster)).enumerate() {
        *s = (a | b) & bits::valid_mask(w, nc);
    }
    let seeded: usize = seen.iter().map(|w| w.count_ones() as usize).sum();
    if 2 * seeded <= nc {
        seen.fill(0);
        vis.fill(0);
        for (w, (&a, &b)) in through.iter().zip(of_cluster).enumerate() {
            for c in bits::word_ones(w, (a | b) & bits::valid_mask(w, nc)) {
                see(seen, vis, g, c as u32);
            }
        }
        return;
    }
    for (w, v) in vis.iter_mut().enumerate() {
        *v = bits::valid_mask(w, n);
    }
    for (c, incoming) in g.cluster_incoming.iter().enumerate() {
        if !bits::get(seen, c) {
            for &q in incoming {
                bits::clear(vis, q as usize);
            }
        }
    }
}

impl Frame {
    /// Portal `pi` is still in `might`.
    #[inline]
    fn may_see(&self, pi: usize) -> bool {
        (self.lo..self.hi).contains(&bits::word_of(pi)) && bits::get(&self.might, pi)
    }

    /// Target portal `pi` is worth testing: it leads into a cluster not yet `seen`, or beyond
    /// it lies something new ([`Frame::leads_on`]).
    #[inline]
    fn worth(&self, g: &Graph, test: &[u64], pi: usize, seen: &[u64], vis: &[u64]) -> bool {
        !bits::get(seen, g.leaves[pi] as usize) || self.leads_on(test, pi, vis)
    }

    /// Lists the frame's portals not yet covered in `vis` ([`Frame::uncovered`]) when there are
    /// at most [`FEW_UNCOVERED`]; `open` must be listed.
    fn list_uncovered(&mut self, vis: &[u64]) {
        self.uncovered.clear();
        for &w in &self.open {
            for u in bits::word_ones(w, self.might[w] & !vis[w]) {
                if self.uncovered.len() == FEW_UNCOVERED {
                    self.uncovered.clear();
                    return;
                }
                self.uncovered.push(u as u32);
            }
        }
    }

    /// `might` and the row of target `pi` (in `test`, `words` a row) share a portal not yet
    /// covered in `vis`: beyond the target lies something new. Only the frame's
    /// [`Frame::open`] words can hold one. With few such portals listed ([`Frame::uncovered`]),
    /// each one `u` still uncovered is looked up instead: `u` is in row `pi` exactly when
    /// `pi ^ 1` is in row `u ^ 1`, since the rows are kept in consistent pairs
    /// ([`super::symmetry`]), and those few rows stay in cache from target to target where the
    /// targets' own rows would each be a miss (a merged cluster has thousands of targets).
    #[inline]
    fn leads_on(&self, test: &[u64], pi: usize, vis: &[u64]) -> bool {
        let words = self.might.len();
        if self.uncovered.is_empty() {
            let trow = &test[pi * words..(pi + 1) * words];
            return self.open.iter().any(|&w| self.might[w] & trow[w] & !vis[w] != 0);
        }
        self.uncovered.iter().any(|&u| {
            let (u, back) = (u as usize, u as usize ^ 1);
            self.may_see(u)
                && !bits::get(vis, u)
                && bits::get(&test[back * words..(back + 1) * words], pi ^ 1)
        })
    }

    /// Compute list `k` of the separators of (`source`, `pass`) (0: normal order, 1: flipped)
    /// unless cached.
    fn ensure_separators(&mut self, k: usize, convex: bool) {
        if self.seps_ready[k] {
            return;
        }
        let flip = k == 1;
        let (a, b) = if flip { (&self.pass, &self.source) } else { (&self.source, &self.pass) };
        let list = &mut self.seps[k];
        list.clear();
        for_each_separator(a, b, flip, convex, |plane| {
            list.push(*plane);
            true
        });
        self.seps_ready[k] = true;
    }
}

/// Tests 1 and 2 (by level): clip the target (`next.pass`) by the separators of the source and
/// the pass portal, from the frame's cache when the source was not changed for this target.
fn clip_target(
    level: u8,
    convex: bool,
    prev: &mut Frame,
    next: &mut Frame,
    source_clip: Clip,
    target: &Sphere,
    scratch: &mut Scratch,
) -> bool {
    let Scratch { tmp, sight } = scratch;
    if level == 0 {
        return true;
    }
    if source_clip == Clip::Whole {
        for k in 0..if level < 2 { 1 } else { 2 } {
            prev.ensure_separators(k, convex);
            // As for the first list before the target was loaded (see [`Flow::recurse`]).
            if k > 0 && prev.seps[k].iter().any(|plane| target.behind(plane)) {
                return false;
            }
            for plane in &prev.seps[k] {
                if next.pass.clip_in(target, plane, CLIP_EPSILON, tmp) == Clip::Gone {
                    return false;
                }
            }
        }
        return true;
    }
    if sight.all_through(&next.pass, &prev.pass, &next.source) {
        return true;
    }
    if !clip_to_separators(&next.source, &prev.pass, false, convex, &mut next.pass, target, tmp) {
        return false;
    }
    level < 2 || clip_to_separators(&prev.pass, &next.source, true, convex, &mut next.pass, target, tmp)
}

/// Tests 3 and 4 for the last frame of `frames`: clip its source by the separators of (its pass,
/// the previous pass) and of (previous pass, its pass). Run lazily, when the frame first has a
/// target to test; until then the portal that led to it already counts as visible, which can
/// only keep more. Returns `false` when no source is left.
fn narrow_source(level: u8, convex: bool, frames: &mut [Frame], head: &Head, scratch: &mut Scratch) -> bool {
    let [.., prev, cur] = frames else { return true };
    let Scratch { tmp, sight } = scratch;
    if sight.all_through(&cur.source, &prev.pass, &cur.pass) {
        return true;
    }
    if !clip_to_separators(&cur.pass, &prev.pass, false, convex, &mut cur.source, &head.bound, tmp) {
        return false;
    }
    level < 4 || clip_to_separators(&prev.pass, &cur.pass, true, convex, &mut cur.source, &head.bound, tmp)
}

#[cfg(test)]
mod tests;
