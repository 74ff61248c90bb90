//! Box queries and spatially coherent groups of triangles.

use glam::{Vec3, Vec4};

use crate::collapse::subtree_ranges;
use crate::stack::Stack;
use crate::{Bvh, STACK, STACK_DEEP, STACK_SMALL};

impl Bvh {
    /// Split the triangles into spatially coherent groups: call `f` once per largest subtree that
    /// holds at most `max` triangles (or per leaf, when a leaf holds more), with the indices (in
    /// the build slice) of its triangles, in a fixed order. Every triangle is in exactly one group.
    pub fn groups(&self, max: usize, mut f: impl FnMut(&[u32])) {
        if self.ids.is_empty() {
            return;
        }
        let range = subtree_ranges(&self.nodes);
        let mut stack = [0u32; STACK];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp] as usize;
            let (a, b) = (range[ni].0 as usize, range[ni].1 as usize);
            let node = &self.nodes[ni];
            if node.count() > 0 || b - a <= max || sp + 2 > STACK {
                f(&self.ids[a..b]);
            } else {
                stack[sp] = node.first() + 1;
                stack[sp + 1] = node.first();
                sp += 2;
            }
        }
    }

    /// Call `f` with the index (in the build slice) of every triangle whose bounding box overlaps
    /// the box `min..max` (closed boxes: touching counts), in a fixed order, until `f` returns
    /// false.
    pub fn overlapping(&self, min: Vec3, max: Vec3, f: impl FnMut(u32) -> bool) {
        if self.deep {
            self.overlapping_in::<STACK_DEEP>(min, max, f);
        } else {
            self.overlapping_in::<STACK_SMALL>(min, max, f);
        }
    }

    /// [`Bvh::overlapping`] through the 4-wide tree (four child boxes, then four triangle boxes, per
    /// SIMD test), children in lane order: the binary tree's left-to-right order, so triangles come
    /// in build order. `N` is a stack of at least the tree's need (as in `walk`).
    fn overlapping_in<const N: usize>(&self, min: Vec3, max: Vec3, mut f: impl FnMut(u32) -> bool) {
        let Some(root) = self.nodes.first() else {
            return;
        };
        let (x0, y0, z0) = (Vec4::splat(min.x), Vec4::splat(min.y), Vec4::splat(min.z));
        let (x1, y1, z1) = (Vec4::splat(max.x), Vec4::splat(max.y), Vec4::splat(max.z));
        // Lanes whose box `[lo, hi]` (one plane per vector) meets the query box; NaN never does.
        let meets = |lo: [Vec4; 3], hi: [Vec4; 3]| {
            (lo[0].cmple(x1)
                & lo[1].cmple(y1)
                & lo[2].cmple(z1)
                & hi[0].cmpge(x0)
                & hi[1].cmpge(y0)
                & hi[2].cmpge(z0))
            .bitmask()
        };
        let mut stack = Stack::<(u32, u32), N>::new();
        // The root: a leaf (its blocks start at 0), or quad 0.
        let (mut first, mut count) = (0, root.count());
        loop {
            if count > 0 {
                let first = first as usize;
                for b in self.blocks.get(first..first + count.div_ceil(4) as usize).unwrap_or_default() {
                    let p = &b.p;
                    let lo = std::array::from_fn(|k| p[0][k].min(p[1][k]).min(p[2][k]));
                    let hi = std::array::from_fn(|k| p[0][k].max(p[1][k]).max(p[2][k]));
                    let mut mask = meets(lo, hi) & ((1 << b.n) - 1);
                    while mask != 0 {
                        let k = b.first as usize + mask.trailing_zeros() as usize;
                        if let Some(&id) = self.ids.get(k)
                            && !f(id)
                        {
                            return;
                        }
                        mask &= mask - 1;
                    }
                }
            } else if let Some(q) = self.quads.get(first as usize) {
                let p = &q.planes;
                let mask = meets([p[0], p[2], p[4]], [p[1], p[3], p[5]]);
                if mask != 0 {
                    // The first lane now, the others (last lane deepest) later.
                    for i in (mask.trailing_zeros() as usize + 1..4).rev() {
                        if mask & (1 << i) != 0 {
                            stack.push((q.first[i], q.count[i]));
                        }
                    }
                    let i = mask.trailing_zeros() as usize;
                    (first, count) = (q.first[i], q.count[i]);
                    continue;
                }
            }
            let Some(next) = stack.pop() else {
                return;
            };
            (first, count) = next;
        }
    }
}
