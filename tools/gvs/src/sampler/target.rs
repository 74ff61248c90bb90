//! Target sampling (this project's extension): rays aimed at groups of nearby triangles none of
//! which was found, once random sampling has ended.

use glam::Vec3;

use crate::components::Components;
use crate::geom::Cell;
use crate::geom::Halton5;

use super::{Class, Gvs};

/// Default of [`Params::target_rays`](super::Params::target_rays), the most rays target sampling aims at one triangle (from
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

impl Gvs<'_> {
    /// Target sampling (this project's extension, "target"): random rays rarely hit small
    /// isolated objects far away (the thesis' Table 6 misses at the scene's periphery: neither
    /// connected surfaces nor occluders, so ABS and reverse sampling never reach them), nor lone
    /// triangles among found objects. Once random sampling has ended, every group of nearby
    /// triangles ([`TargetGroups`](crate::targets::TargetGroups), built once per scene) with triangles of unreached surface
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
    pub(super) fn sample_targets(&mut self) {
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
}
