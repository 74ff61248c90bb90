//! Frames a flow has finished exploring, kept so that a later frame they cover is not explored
//! again.
//!
//! What a flow does beyond a frame depends only on the frame's cluster, its clipped source and
//! pass windings and its `might`, and on the clusters seen so far, which only grow. Exploring a
//! frame finds (conservatively) every cluster that a line through its source and pass reaches
//! along portals of its `might`. A later frame entered through the same portal, whose source lies
//! inside the earlier frame's source, whose pass lies inside the earlier pass and whose `might`
//! is a subset of the earlier one's, carries a subset of those lines along a subset of those
//! portals: everything it could find, the earlier frame found or ruled out, so it is skipped. The
//! PVS can only get tighter, never hide a leaf a line reaches: the earlier frame was conservative
//! for all of its lines.
//!
//! A frame is kept once explored, with its source as tests 3 and 4 narrowed it and its `might` as
//! beam culls left it (a subset of what it held on entry: it covers less). Only frames whose
//! exploration visited at least [`KEEP_CHAINS`] chains are kept: a smaller one is cheaper to
//! explore again than to keep and check. Storage is bounded per flow ([`EXPLORED_ROWS`]); once a
//! flow has filled it, the flow forgets every frame it kept and starts again from the next one
//! ([`Explored::keep`]). The bound counts
//! what the flow's storage would hold had it grown from empty, so what a flow keeps, and so its
//! chains, do not depend on the flows its thread ran before (the same for any thread count). The
//! allocations themselves are kept from flow to flow while under a third of the bound, and a flow
//! keeps at most two thirds of it, so what a thread holds stays under the bound.
//!
//! Containment is tested against each kept winding's edges: every point of the new winding at
//! most [`TOUCH_EPSILON`] outside every edge. A winding sliver that thin passes no sight
//! ([`super::poly`]); a kept winding that turns clockwise about its normal, or has fewer than three
//! points, covers nothing.

use glam::DVec3;
use sightline_formats::bits;

use super::poly::{Poly, TOUCH_EPSILON};

/// The most bytes a thread allocates for explored frames (their `might` words, windings and
/// boxes, counted by capacity), in rows of `might`: the store of a map with `n` one-way portals
/// holds up to this many times `n / 8` bytes, at most [`EXPLORED_BYTES`]. On the generated
/// `terrain_32` (our own portals, 63 words a row) a flow would use 4.6 MB at most; with 8,192 rows
/// (4.1 MB) it visited 2.90 M chains, and 4.05 M without the store (session 21, when a flow could
/// keep up to the whole bound; counting use rather than capacity, which bounds the memory less
/// tightly: 4,096 rows 2.95 M, 8,192 rows 2.81 M, 16 MiB 2.80 M).
pub const EXPLORED_ROWS: usize = 8192;

/// The most bytes a thread keeps for explored frames, whatever the map.
pub const EXPLORED_BYTES: usize = 16 << 20;

/// Chains a frame's exploration must have visited (itself included) for the frame to be kept.
/// Where frames are rarely covered (the generated arenas: 0.3 % of the checks) keeping every frame
/// that went deeper costs 3.6 % more instructions; with 16, 1 %, for most of the gain on the
/// terrain (21 % fewer instructions on `terrain_24`, against 24 % keeping every such frame).
pub const KEEP_CHAINS: u64 = 16;

/// A frame explored: where its `might` words and windings are kept.
#[derive(Debug, Clone, Copy)]
struct Entry {
    /// Its `might` is zero outside words `lo..hi`, kept from `at` in [`Explored::words`].
    lo: u32,
    hi: u32,
    at: u32,
    /// Its source's points from `points` in [`Explored::points`], then its pass's.
    points: u32,
    source_points: u16,
    pass_points: u16,
    /// Its pass's bounding box, rounded outward: a winding inside the pass is inside the box.
    low: [f32; 3],
    high: [f32; 3],
}

/// The frames one flow has explored, per portal they were entered through (see the module doc).
#[derive(Debug)]
pub struct Explored {
    /// Per one-way portal, its entries this flow (reused from flow to flow).
    by_portal: Vec<Vec<Entry>>,
    /// One bit per one-way portal: it has entries this flow (read before the list, which is
    /// likelier to be out of cache).
    has: Vec<u64>,
    /// Portals with entries this flow.
    touched: Vec<u32>,
    /// Portals whose list holds an allocation (kept from flow to flow), and its bytes in all.
    holding: Vec<u32>,
    held: usize,
    words: Vec<u64>,
    points: Vec<DVec3>,
    /// This flow's storage as if grown from empty ([`grown`]): the capacities of `words`,
    /// `points` and `touched`, and its bytes in all (the lists' counted by [`list_capacity`]).
    virtual_words: usize,
    virtual_points: usize,
    virtual_touched: usize,
    kept: usize,
    /// The most bytes kept ([`EXPLORED_ROWS`]).
    bound: usize,
}

impl Explored {
    /// Storage for `portals` one-way portals.
    pub fn new(portals: usize) -> Self {
        Self {
            by_portal: vec![Vec::new(); portals],
            has: vec![0; bits::words(portals)],
            touched: Vec::new(),
            holding: Vec::new(),
            held: 0,
            words: Vec::new(),
            points: Vec::new(),
            virtual_words: 0,
            virtual_points: 0,
            virtual_touched: 0,
            kept: 0,
            bound: Self::bound(portals),
        }
    }

    /// The most bytes kept for explored frames for `portals` one-way portals ([`EXPLORED_ROWS`]).
    fn bound(portals: usize) -> usize {
        EXPLORED_ROWS.saturating_mul(8 * bits::words(portals)).min(EXPLORED_BYTES)
    }

    /// The bytes kept for `portals` one-way portals at most: the lists' headers, one bit and
    /// two `holding` slots each (a vector that doubles), and the bound (a flow starts with at
    /// most a third of it allocated, [`Explored::clear`], and keeps at most two thirds,
    /// [`Explored::keep`]).
    pub fn bytes(portals: usize) -> u128 {
        ((std::mem::size_of::<Vec<Entry>>() + 9) * portals + Self::bound(portals)) as u128
    }

    /// Forget every frame and free their storage: the flow's storage counts from empty again.
    fn forget(&mut self) {
        self.clear();
        self.free();
    }

    /// Free the storage of an empty store.
    fn free(&mut self) {
        for &p in &self.holding {
            self.by_portal[p as usize] = Vec::new();
        }
        self.holding = Vec::new();
        self.held = 0;
        self.touched = Vec::new();
        self.words = Vec::new();
        self.points = Vec::new();
    }

    /// Forget every frame (a new flow starts).
    pub fn clear(&mut self) {
        for &p in &self.touched {
            self.by_portal[p as usize].clear();
            bits::clear(&mut self.has, p as usize);
        }
        self.touched.clear();
        self.words.clear();
        self.points.clear();
        (self.virtual_words, self.virtual_points, self.virtual_touched, self.kept) = (0, 0, 0, 0);
        if self.allocated() > self.bound / 3 {
            self.free();
        }
    }

    /// Bytes allocated: the lists' (also those of earlier flows, still held), and the
    /// capacities of the `might` words, the points and the portal lists.
    fn allocated(&self) -> usize {
        self.held
            + self.words.capacity() * 8
            + self.points.capacity() * std::mem::size_of::<DVec3>()
            + (self.touched.capacity() + self.holding.capacity()) * 4
    }

    /// A frame entered through `portal` with these windings and `might` (zero outside words
    /// `lo..hi`) is covered by one explored before.
    pub fn covers(
        &self,
        portal: usize,
        source: &Poly,
        pass: &Poly,
        might: &[u64],
        lo: usize,
        hi: usize,
    ) -> bool {
        if !bits::get(&self.has, portal) {
            return false;
        }
        let list = &self.by_portal[portal];
        let (low, high) = corners(pass);
        list.iter().any(|e| {
            let (elo, ehi) = (e.lo as usize, e.hi as usize);
            if (lo < hi && (lo < elo || hi > ehi))
                || (0..3).any(|k| low[k] < f64::from(e.low[k]) || high[k] > f64::from(e.high[k]))
            {
                return false;
            }
            let points = &self.points[e.points as usize..];
            let (source_points, pass_points) = points.split_at(usize::from(e.source_points));
            let kept = &self.words[e.at as usize..][..ehi - elo];
            within(pass, &pass_points[..usize::from(e.pass_points)])
                && (lo..hi).all(|w| might[w] & !kept[w - elo] == 0)
                && within(source, source_points)
        })
    }

    /// Keep a frame entered through `portal`, now explored: its windings (`source` as narrowed)
    /// and its `might` (zero outside words `lo..hi`). When the flow's storage, counted as grown
    /// from empty, would pass two thirds of the bound, every frame kept so far is forgotten (and
    /// its storage freed) first; a frame that alone would pass it is not kept.
    ///
    /// Forgetting rather than keeping no more: a depth-first flow meets again the portals of the
    /// frames it explored last, and once a flow kept no more, each route into a region it had
    /// explored explored it again, and so on beneath. On the generated `city_36` (our compile,
    /// 16,884 one-way portals, rows of 2.1 KB, a bound of 16 MiB: about 5,000 frames) one flow of
    /// 16,884 made 95.6 M of the map's 195 M chains and took 225 of its 381 CPU seconds; forgetting,
    /// the map made 65.4 M chains, as many as with a bound of 128 MiB (64.9 M), for 115 MB of peak
    /// memory against 269 MB (session 28, `docs/benchmarks.md`).
    pub fn keep(&mut self, portal: usize, source: &Poly, pass: &Poly, might: &[u64], lo: usize, hi: usize) {
        let (lo, hi) = if lo < hi { (lo, hi) } else { (0, 0) };
        let len = self.by_portal[portal].len();
        let caps = [
            grown(self.virtual_words, self.words.len(), hi - lo),
            grown(self.virtual_points, self.points.len(), source.n + pass.n),
            grown(self.virtual_touched, self.touched.len(), usize::from(len == 0)),
            list_capacity(len + 1),
        ];
        let more = (caps[0] - self.virtual_words) * 8
            + (caps[1] - self.virtual_points) * std::mem::size_of::<DVec3>()
            + (caps[2] - self.virtual_touched) * 4
            + (caps[3] - list_capacity(len)) * std::mem::size_of::<Entry>();
        if self.kept + more > self.bound / 3 * 2 {
            if self.kept == 0 {
                return;
            }
            self.forget();
            return self.keep(portal, source, pass, might, lo, hi);
        }
        let (Ok(at), Ok(points), Ok(source_points), Ok(pass_points)) = (
            u32::try_from(self.words.len()),
            u32::try_from(self.points.len()),
            u16::try_from(source.n),
            u16::try_from(pass.n),
        ) else {
            return;
        };
        self.kept += more;
        [self.virtual_words, self.virtual_points, self.virtual_touched] = [caps[0], caps[1], caps[2]];
        reserve(&mut self.words, caps[0]);
        reserve(&mut self.points, caps[1]);
        reserve(&mut self.touched, caps[2]);
        self.words.extend_from_slice(&might[lo..hi]);
        self.points.extend_from_slice(&source.p[..source.n]);
        self.points.extend_from_slice(&pass.p[..pass.n]);
        let (low, high) = corners(pass);
        let entry = Entry {
            lo: lo as u32,
            hi: hi as u32,
            at,
            points,
            source_points,
            pass_points,
            low: low.map(|x| down(x - TOUCH_EPSILON)),
            high: high.map(|x| -down(-(x + TOUCH_EPSILON))),
        };
        let list = &mut self.by_portal[portal];
        let capacity = list.capacity();
        reserve(list, caps[3]);
        self.held += (list.capacity() - capacity) * std::mem::size_of::<Entry>();
        if capacity == 0 {
            self.holding.push(portal as u32);
        }
        if list.is_empty() {
            self.touched.push(portal as u32);
            bits::set(&mut self.has, portal);
        }
        list.push(entry);
    }
}

/// The capacity a vector of `capacity` holding `len` elements grows to for `extra` more: its own
/// while they fit, else a quarter more, at least what they need and 4. (Capacity counts toward
/// the bound, so doubling would leave up to half of it unused.)
fn grown(capacity: usize, len: usize, extra: usize) -> usize {
    let need = len + extra;
    if need <= capacity { capacity } else { (capacity + capacity / 4).max(need).max(4) }
}

/// The capacity of a list grown from empty to `len` entries one at a time ([`grown`]).
fn list_capacity(len: usize) -> usize {
    let mut capacity = 0;
    while capacity < len {
        capacity = grown(capacity, capacity, 1);
    }
    capacity
}

/// Grow `v` to exactly `capacity` (when larger than its own).
fn reserve<T>(v: &mut Vec<T>, capacity: usize) {
    if capacity > v.capacity() {
        v.reserve_exact(capacity - v.len());
    }
}

/// `x` as an `f32` no greater than it.
fn down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x { y.next_down() } else { y }
}

/// The corners of `w`'s bounding box.
#[inline]
fn corners(w: &Poly) -> ([f64; 3], [f64; 3]) {
    let pts = &w.p[..w.n];
    let low = pts.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let high = pts.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    (low.to_array(), high.to_array())
}

/// Every point of `w` lies at most [`TOUCH_EPSILON`] outside each edge of `kept`, a winding of
/// `w`'s plane turning counter-clockwise about `w`'s normal ([`Poly`]).
#[inline]
fn within(w: &Poly, kept: &[DVec3]) -> bool {
    let Some(&last) = kept.last() else { return false };
    if kept.len() < 3 {
        return false;
    }
    let mut a = last;
    kept.iter().all(|&b| {
        // Pointing into `kept`, as long as the edge.
        let m = w.normal.cross(b - a);
        let limit = TOUCH_EPSILON * TOUCH_EPSILON * m.length_squared();
        a = b;
        w.p[..w.n].iter().all(|&x| {
            let d = m.dot(x - b);
            d >= 0.0 || d * d <= limit
        })
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// A square of side `size` in the plane `x = 0`, from `(0, y, z)`, counter-clockwise about +x.
    fn square(y: f64, z: f64, size: f64) -> Poly {
        let mut p = Poly::default();
        let pts =
            [(0.0, 0.0), (size, 0.0), (size, size), (0.0, size)].map(|(a, b)| DVec3::new(0.0, y + a, z + b));
        p.load(&pts, DVec3::X);
        p
    }

    #[test]
    fn a_frame_is_covered_only_by_a_wider_one_with_more_in_might() {
        let mut ex = Explored::new(8);
        let (big, small) = (square(0.0, 0.0, 64.0), square(16.0, 16.0, 32.0));
        let wide = [0u64, 0b1111, 0b1];
        assert!(!ex.covers(3, &small, &small, &wide, 1, 3), "nothing kept yet");
        ex.keep(3, &big, &big, &wide, 1, 3);
        assert!(ex.covers(3, &small, &small, &[0, 0b0101, 0b1], 1, 3));
        assert!(ex.covers(3, &big, &big, &wide, 1, 3), "the same frame again");
        assert!(ex.covers(3, &small, &small, &[0, 0, 0], 0, 0), "an empty might");
        assert!(!ex.covers(3, &small, &small, &[0, 0b10000, 0], 1, 2), "a portal it did not have");
        assert!(!ex.covers(3, &small, &small, &[1, 0, 0], 0, 1), "a word it did not keep");
        assert!(!ex.covers(3, &square(-1.0, 0.0, 8.0), &small, &wide, 1, 3), "a source reaching out");
        assert!(!ex.covers(3, &small, &square(60.0, 60.0, 8.0), &wide, 1, 3), "a pass reaching out");
        assert!(!ex.covers(2, &small, &small, &wide, 1, 3), "another portal");
        ex.clear();
        assert!(!ex.covers(3, &small, &small, &wide, 1, 3), "a new flow");
    }

    #[test]
    fn a_winding_turning_the_other_way_covers_nothing() {
        let mut ex = Explored::new(1);
        let mut turned = square(0.0, 0.0, 64.0);
        turned.p[..4].reverse();
        ex.keep(0, &turned, &turned, &[1], 0, 1);
        let small = square(16.0, 16.0, 8.0);
        assert!(!ex.covers(0, &small, &small, &[1], 0, 1));
    }

    #[test]
    fn storage_forgets_at_its_bound() {
        let mut ex = Explored::new(2);
        assert_eq!(ex.bound, EXPLORED_ROWS * 8, "a row of one word");
        ex.bound = EXPLORED_BYTES;
        let row = vec![u64::MAX; 1 << 16];
        let (w, first) = (square(0.0, 0.0, 1.0), square(8.0, 8.0, 1.0));
        ex.keep(0, &first, &first, &row, 0, row.len());
        let (mut most, mut forgot) = (0, false);
        for _ in 0..EXPLORED_BYTES / (8 << 16) + 2 {
            let before = ex.by_portal[1].len();
            ex.keep(1, &w, &w, &row, 0, row.len());
            assert!(ex.kept <= ex.bound / 3 * 2 && ex.allocated() <= ex.bound);
            forgot |= ex.by_portal[1].len() == 1 && before > 0;
            most = most.max(ex.by_portal[1].len());
        }
        assert!(forgot && most > 1 && most < ex.bound / (8 << 16), "filled, then forgot");
        assert!(!ex.covers(0, &first, &first, &row, 0, row.len()), "the frame kept first is forgotten");
        assert!(ex.covers(1, &w, &w, &row, 0, row.len()), "the frame kept last covers");
        let alone = vec![u64::MAX; EXPLORED_BYTES / 8];
        ex.keep(0, &w, &w, &alone, 0, alone.len());
        assert!(ex.kept <= ex.bound / 3 * 2 && !ex.covers(0, &w, &w, &alone, 0, alone.len()));
    }

    /// What a flow keeps does not depend on the flows before it: a store that ran other flows
    /// first keeps exactly what a fresh one keeps. What earlier flows allocated is released
    /// once over a third of the bound, so a flow starts with at most that allocated.
    #[test]
    fn a_flow_keeps_the_same_after_any_earlier_flows() {
        let w = square(0.0, 0.0, 1.0);
        let flow = |ex: &mut Explored, portals: std::ops::Range<usize>, frames: usize| {
            for p in portals {
                for _ in 0..frames {
                    ex.keep(p, &w, &w, &[1, 1], 0, 2);
                }
            }
            assert!(ex.kept <= ex.bound / 3 * 2);
            (0..64).map(|p| ex.by_portal[p].len()).collect::<Vec<_>>()
        };
        let mut fresh = Explored::new(64);
        fresh.bound = 1 << 12;
        let want = flow(&mut fresh, 0..64, 32);
        assert!(want.iter().sum::<usize>() < 64 * 32, "the bound was not reached");
        let mut used = Explored::new(64);
        used.bound = 1 << 12;
        for (earlier, frames) in [(0..1, 100), (63..64, 7), (20..40, 3), (0..64, 32)] {
            flow(&mut used, earlier, frames);
            used.clear();
            assert!(used.allocated() <= used.bound / 3, "{} allocated", used.allocated());
            assert_eq!(flow(&mut used, 0..64, 32), want);
            used.clear();
        }
    }

    proptest! {
        /// A convex winding shrunk toward its middle (or the winding itself, `t = 1`) is covered
        /// by it; one with a point a unit beyond one of its edges is not.
        #[test]
        fn containment_matches_the_geometry(
            pts in prop::collection::vec((-100.0f64..100.0, -100.0f64..100.0), 3..9),
            t in 0.0f64..=1.0,
            edge in 0usize..8,
        ) {
            // A convex winding: the points' angles around the origin, sorted, on a circle.
            let mut angles: Vec<f64> = pts.iter().map(|&(a, b)| b.atan2(a)).collect();
            angles.sort_by(f64::total_cmp);
            angles.dedup_by(|a, b| (*a - *b).abs() < 1e-3);
            prop_assume!(angles.len() >= 3);
            let ring: Vec<DVec3> = angles.iter().map(|a| DVec3::new(0.0, 50.0 * a.cos(), 50.0 * a.sin())).collect();
            let mut kept = Poly::default();
            kept.load(&ring, DVec3::X);
            let middle = ring.iter().sum::<DVec3>() / ring.len() as f64;
            let inner: Vec<DVec3> = ring.iter().map(|&p| middle + (p - middle) * t).collect();
            let mut small = Poly::default();
            small.load(&inner, DVec3::X);
            let mut ex = Explored::new(1);
            ex.keep(0, &kept, &kept, &[1], 0, 1);
            prop_assert!(ex.covers(0, &small, &small, &[1], 0, 1));
            // One point pushed a unit beyond the middle of one edge.
            let i = edge % ring.len();
            let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
            let out = DVec3::X.cross(b - a).normalize() * -1.0 + (a + b) * 0.5;
            let mut beyond = small.clone();
            beyond.p[0] = out;
            prop_assert!(!ex.covers(0, &beyond, &small, &[1], 0, 1));
            prop_assert!(!ex.covers(0, &small, &beyond, &[1], 0, 1));
        }
    }
}
