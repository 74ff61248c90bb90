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
//! frame; tests 3 and 4 run only when the frame below has a target to test. All clips round toward
//! visible (see [`super::poly`]).
//!
//! Beam culling: on entering a frame that still has uncovered portals in `might`, those lying
//! wholly behind one of the frame's separators (or its pass plane) are dropped from `might`, so a
//! branch dies as soon as nothing it could still reach is new. On E1M1 this cuts the chains
//! visited from 4.0 M to 0.93 M.
//!
//! Seeds: clusters known visible from the source's cluster by a certified line
//! ([`super::certify`]) count as seen from the start; the flow records new certified lines for
//! later flows.
//!
//! The result of a flow is the set of portals it might see that lead into a cluster it sees: a
//! superset of the portals truly visible through the source, so later flows may narrow by it.

use glam::DVec3;
use sightline_formats::geom::Plane;

use super::certify;
use super::graph::Graph;
use super::poly::{CLIP_EPSILON, Clip, Poly, Sphere, TOUCH_EPSILON, clip_to_separators, for_each_separator};
use sightline_formats::bits;

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
    /// Words of `might` outside `lo..hi` are zero (and not stored).
    lo: usize,
    hi: usize,
    /// Separators of (`source`, `pass`): normal order then flipped order.
    seps: [Vec<Plane>; 2],
    seps_ready: bool,
    /// Tests 3 and 4 (narrowing `source`) are still to run.
    narrow: bool,
}

/// Per-thread flow state, reused from portal to portal (no allocation once frames exist).
#[derive(Debug)]
pub struct Flow {
    frames: Vec<Frame>,
    tmp: Poly,
    /// Portals leading into a cluster already known visible from the base portal.
    vis: Vec<u64>,
    /// Clusters known visible from the base portal.
    seen: Vec<u64>,
    words: usize,
    level: u8,
    /// Recursive calls made (portal chains visited).
    pub chains: u64,
    /// Look for certified sight lines (for seeds).
    seeding: bool,
    /// Seeds found by the last run: (cluster, cluster) pairs joined by a certified line (see
    /// [`super::certify`]), the first seeing the second.
    pub certified: Vec<(u32, u32)>,
}

impl Flow {
    /// State for rows of `words` words and separator `level` 0..=4; `seeding` looks for
    /// certified sight lines.
    pub fn new(words: usize, clusters: usize, level: u8, seeding: bool) -> Self {
        Self {
            frames: Vec::new(),
            tmp: Poly::default(),
            vis: vec![0; words],
            seen: vec![0; bits::words(clusters)],
            words,
            level,
            chains: 0,
            seeding,
            certified: Vec::new(),
        }
    }

    /// Cluster `c` is visible: every portal into it is covered.
    fn see(&mut self, g: &Graph, c: u32) {
        if bits::get(&self.seen, c as usize) {
            return;
        }
        bits::set(&mut self.seen, c as usize);
        for &q in &g.cluster_incoming[c as usize] {
            bits::set(&mut self.vis, q as usize);
        }
    }

    fn frame(&mut self, d: usize) {
        while self.frames.len() <= d {
            self.frames.push(Frame { might: vec![0; self.words], ..Frame::default() });
        }
    }

    /// The portals visible through portal `base`; `test` holds per portal its final vis when done,
    /// else its `mightsee` (`words` words per portal). Writes the result into `out`.
    ///
    /// `seeds` holds clusters known visible from the cluster `base` leaves by a certified line:
    /// they are marked seen from the start, so branches that could only find them are not
    /// explored. The row stays a superset of what `base` sees (it may also hold portals into
    /// clusters seen only through the cluster's other portals, which the cluster's row holds
    /// anyway). The run leaves in [`Flow::certified`] the seeds it found.
    pub fn run(&mut self, g: &Graph, test: &[u64], seeds: &[u64], base: usize, out: &mut [u64]) {
        self.vis.fill(0);
        self.seen.fill(0);
        self.certified.clear();
        for c in bits::ones(seeds) {
            self.see(g, c as u32);
        }
        let p = &g.portals[base];
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
        f.seps_ready = false;
        f.narrow = false;
        let head = Head { plane: p.plane, bound: Sphere { center: p.center, radius: p.radius } };
        self.recurse(g, test, 0, &head);
        // Portals it might see that lead into a cluster it sees: a superset of the portals it
        // sees, which is what later flows may narrow by.
        let might = &test[base * self.words..(base + 1) * self.words];
        for ((o, &v), &m) in out.iter_mut().zip(&self.vis).zip(might) {
            *o = v & m;
        }
    }

    fn recurse(&mut self, g: &Graph, test: &[u64], d: usize, head: &Head) {
        self.chains += 1;
        let words = self.words;
        self.frame(d + 1);
        let leaf = self.frames[d].leaf as usize;
        // Without a target worth testing (one still possibly visible that leads to an unseen
        // cluster or beyond which something unseen might lie) the branch ends here, before the
        // frame's separators are built. The loop below applies the same tests.
        let here = &self.frames[d];
        let (lo, hi) = (here.lo, here.hi);
        let worth = g.cluster_portals[leaf].iter().any(|&pi| {
            let pi = pi as usize;
            if !here.may_see(pi) {
                return false;
            }
            !bits::get(&self.seen, g.portals[pi].leaf as usize)
                || (lo..hi).any(|w| here.might[w] & test[pi * words + w] & !self.vis[w] != 0)
        });
        if !worth {
            return;
        }
        if d > 0 && self.level > 0 && !self.cull_beyond_beam(g, d, head) {
            return;
        }
        for &pi in &g.cluster_portals[leaf] {
            let pi = pi as usize;
            if !self.frames[d].may_see(pi) {
                continue;
            }
            let p = &g.portals[pi];
            let (lo, hi) = self.frames.split_at_mut(d + 1);
            let (prev, next) = (&mut lo[d], &mut hi[0]);
            let trow = &test[pi * words..(pi + 1) * words];
            let mut more = 0u64;
            let (mut first, mut last) = (prev.hi, prev.lo);
            let range = prev.lo..prev.hi;
            let words_in = next.might[range.clone()]
                .iter_mut()
                .zip(&prev.might[range.clone()])
                .zip(&trow[range.clone()])
                .zip(&self.vis[range.clone()]);
            for (w, (((m, &a), &b), &v)) in range.zip(words_in) {
                *m = a & b;
                more |= *m & !v;
                if *m != 0 {
                    first = first.min(w);
                    last = w + 1;
                }
            }
            (next.lo, next.hi) = if first < last { (first, last) } else { (0, 0) };
            // Nothing new beyond `p`: only whether `p` itself is visible is left to decide.
            let deeper = more != 0;
            if !deeper && bits::get(&self.seen, p.leaf as usize) {
                continue;
            }
            // Tests 3 and 4 already narrowed `prev.source` in `cull_beyond_beam`: a frame gets
            // here only with a target worth testing, so with something new in `might`.
            debug_assert!(!prev.narrow);
            let Some(prev_plane) = prev.plane else { continue };
            if p.plane.normal.dot(prev_plane.normal) <= -1.0 + OPPOSITE_EPSILON {
                continue; // straight back out through the way in
            }
            // Target: in front of the source portal (quick sphere test first).
            let tmp = &mut self.tmp;
            next.pass.load(g.winding(p), p.plane.normal);
            let target = Sphere { center: p.center, radius: p.radius };
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
            next.seps_ready = false;
            next.narrow = false;
            if d > 0 {
                // Target: in front of the pass portal.
                if next.pass.clip_in(&target, &prev_plane, CLIP_EPSILON, tmp) == Clip::Gone {
                    continue;
                }
                if !clip_target(self.level, g.convex, prev, next, source_clip, &target, tmp) {
                    continue;
                }
                // Tests 3 and 4 narrow the source for the frame below: deferred until that frame
                // has a target worth testing (see `narrow_source`).
                next.narrow = self.level > 2;
            }
            if !bits::get(&self.seen, p.leaf as usize) {
                self.see(g, p.leaf);
                if self.seeding {
                    self.certify(g, d + 1);
                }
            }
            if deeper {
                self.recurse(g, test, d + 1, head);
            }
        }
    }
}

impl Flow {
    /// Frame `k` was just reached through a new cluster: if the line from the middle of its
    /// clipped source to the middle of its clipped target crosses every original winding of the
    /// chain (frames `1..k`), record seeds: every two clusters the line runs through (from the
    /// base portal's owner to the cluster reached) see each other.
    fn certify(&mut self, g: &Graph, k: usize) {
        let chain = &self.frames[..=k];
        let base = &g.portals[chain[0].portal as usize];
        let target = &g.portals[chain[k].portal as usize];
        let (Some(a), Some(b)) = (
            certify::centroid(&chain[k].source.p[..chain[k].source.n]),
            certify::centroid(&chain[k].pass.p[..chain[k].pass.n]),
        ) else {
            return;
        };
        let ok = base.plane.distance(b) > certify::CERTIFY_MARGIN
            && target.plane.distance(a) < -certify::CERTIFY_MARGIN
            && certify::inside(g.winding(base), base.plane.normal, a)
            && certify::inside(g.winding(target), target.plane.normal, b)
            && certify::crosses(
                a,
                b,
                chain[1..k].iter().map(|f| {
                    let p = &g.portals[f.portal as usize];
                    (&p.plane, g.winding(p))
                }),
            );
        if !ok {
            return;
        }
        for (i, f) in chain.iter().enumerate() {
            let ci = g.portals[f.portal as usize].owner;
            for h in &chain[i + 1..] {
                let cj = g.portals[h.portal as usize].owner;
                self.certified.push((ci, cj));
                self.certified.push((cj, ci));
            }
            self.certified.push((ci, target.leaf));
            self.certified.push((target.leaf, ci));
        }
    }

    /// Drop from frame `d`'s `might` every portal not yet covered that lies wholly behind (or at
    /// most touching) one of the frame's separators or the plane of its pass portal: every line
    /// through the source and the pass lies in front of those planes beyond the pass, so no line
    /// of this branch reaches it. Only uncovered portals keep a branch alive, so testing those is
    /// enough for pruning. Returns `false` when no source is left.
    fn cull_beyond_beam(&mut self, g: &Graph, d: usize, head: &Head) -> bool {
        let (lo, hi) = (self.frames[d].lo, self.frames[d].hi);
        let any_new = (lo..hi).any(|w| self.frames[d].might[w] & !self.vis[w] != 0);
        if !any_new {
            return true;
        }
        if self.frames[d].narrow {
            self.frames[d].narrow = false;
            if !narrow_source(self.level, g.convex, &mut self.frames[..=d], head, &mut self.tmp) {
                return false;
            }
        }
        let f = &mut self.frames[d];
        f.ensure_separators(self.level, g.convex);
        for w in lo..hi {
            for ti in bits::word_ones(w, f.might[w] & !self.vis[w]) {
                let [x, y, z, r] = g.spheres[ti];
                let center = DVec3::new(x, y, z);
                let beyond = |pl: &Plane| {
                    let c = pl.distance(center);
                    c + r <= TOUCH_EPSILON
                        || (c < 0.0
                            && g.winding(&g.portals[ti]).iter().all(|q| pl.distance(*q) <= TOUCH_EPSILON))
                };
                let out = f.plane.as_ref().is_some_and(beyond)
                    || f.seps[0].iter().any(beyond)
                    || f.seps[1].iter().any(beyond);
                if out {
                    f.might[w] &= !bits::mask(ti);
                }
            }
        }
        true
    }
}

impl Frame {
    /// Portal `pi` is still in `might`.
    #[inline]
    fn may_see(&self, pi: usize) -> bool {
        (self.lo..self.hi).contains(&bits::word_of(pi)) && bits::get(&self.might, pi)
    }

    /// Compute the separators of (`source`, `pass`) unless cached.
    fn ensure_separators(&mut self, level: u8, convex: bool) {
        if self.seps_ready {
            return;
        }
        for (k, flip) in [false, true].into_iter().enumerate() {
            self.seps[k].clear();
            if k == 1 && level < 2 {
                break;
            }
            let (a, b) = if flip { (&self.pass, &self.source) } else { (&self.source, &self.pass) };
            let list = &mut self.seps[k];
            for_each_separator(a, b, flip, convex, |plane| {
                list.push(*plane);
                true
            });
        }
        self.seps_ready = true;
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
    tmp: &mut Poly,
) -> bool {
    if level == 0 {
        return true;
    }
    if source_clip == Clip::Whole {
        prev.ensure_separators(level, convex);
        for list in &prev.seps {
            for plane in list {
                if next.pass.clip_in(target, plane, CLIP_EPSILON, tmp) == Clip::Gone {
                    return false;
                }
            }
        }
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
fn narrow_source(level: u8, convex: bool, frames: &mut [Frame], head: &Head, tmp: &mut Poly) -> bool {
    let [.., prev, cur] = frames else { return true };
    if !clip_to_separators(&cur.pass, &prev.pass, false, convex, &mut cur.source, &head.bound, tmp) {
        return false;
    }
    level < 4 || clip_to_separators(&prev.pass, &cur.pass, true, convex, &mut cur.source, &head.bound, tmp)
}
