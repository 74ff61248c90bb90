//! Box queries for entities: which leaves a box touches (Quake's efrags) and whether a box is
//! potentially visible (or hearable) from a PVS or PHS row.
//!
//! # Conventions
//! - Boxes are axis-aligned, world units, given by two opposite corners (an inverted box is the
//!   box spanning both corners).
//! - The descent is **conservative**: a box goes to each side of a node plane it reaches within
//!   [`BOX_EPSILON`] units, so every point of the box (and every point within float rounding of
//!   it) ends in a reported leaf: for every `p` in the box, `World::leaf_at(p)` is among
//!   [`World::leaves_touching`] unless that leaf is solid. A box with a NaN coordinate goes both
//!   ways at every node (every open leaf).
//! - Back faces: a face is behind the eye when `normal · eye - dist < -BACKFACE_EPSILON`; an eye
//!   on the plane or within the epsilon behind it keeps the face (round toward visible).
//! - Only open (non-solid) leaves of the world tree are reported, each once, in tree order (front
//!   child first).

use glam::Vec3A;

use crate::draw::DrawData;
use crate::pvs::Bitset;
use crate::tree::Tree;
use crate::world::{LeafId, World};

/// Slack, in world units, with which a box counts as reaching a side of a node plane: larger than
/// the `f32` rounding of a plane distance anywhere in a Quake-sized world, so a decision near the
/// plane always keeps both sides.
pub const BOX_EPSILON: f32 = 1.0 / 32.0;

/// How far, in world units, the eye may be behind a face's plane and still keep the face.
pub const BACKFACE_EPSILON: f32 = 1.0 / 32.0;

/// True when face `face` is kept by back-face culling from `eye`: the eye is on its front, or
/// at most [`BACKFACE_EPSILON`] behind its plane, or the test is NaN, or the face is out of
/// range. The one copy of the rule (the walk, the reference walk and
/// [`World::cull_back_faces`] call it).
#[inline(always)]
pub(crate) fn front_or_near(draw: &DrawData, face: u32, eye: Vec3A) -> bool {
    draw.face_plane(face).is_none_or(|(n, d)| {
        let side = n.dot(eye) - d;
        side.is_nan() || side >= -BACKFACE_EPSILON
    })
}

/// Centre and half-size of the box spanning `a` and `b`.
fn center_extent(a: Vec3A, b: Vec3A) -> (Vec3A, Vec3A) {
    ((a + b) * 0.5, (b - a).abs() * 0.5)
}

/// Visit the open world leaves the box reaches until `visit` returns `true`; returns whether it
/// did. Recursion is bounded by the validated tree depth.
fn descend(tree: &Tree, child: i32, c: Vec3A, e: Vec3A, visit: &mut dyn FnMut(LeafId, i32) -> bool) -> bool {
    if child < 0 {
        let leaf = (!child) as LeafId;
        return match tree.leaves.get(leaf as usize) {
            Some(l) if l.contents.is_open() => visit(leaf, l.cluster),
            _ => false,
        };
    }
    let Some(node) = tree.nodes.get(child as usize) else { return false };
    let d = node.normal.dot(c) - node.dist;
    let r = node.normal.abs().dot(e);
    // NaN (a NaN box) goes both ways.
    let (front, back) =
        if d.is_nan() || r.is_nan() { (true, true) } else { (d + r >= -BOX_EPSILON, d - r < BOX_EPSILON) };
    (front && descend(tree, node.children[0], c, e, visit))
        || (back && descend(tree, node.children[1], c, e, visit))
}

impl World {
    /// The open leaves of the world tree that the box from `a` to `b` touches, into `out`
    /// (cleared first; no allocation once `out` has room). See the module docs.
    pub fn leaves_touching(&self, a: impl Into<Vec3A>, b: impl Into<Vec3A>, out: &mut Vec<LeafId>) {
        out.clear();
        let (c, e) = center_extent(a.into(), b.into());
        descend(self.tree(), self.tree().root, c, e, &mut |leaf, _| {
            out.push(leaf);
            false
        });
    }

    /// True when the box from `a` to `b` touches an open leaf whose cluster is set in `row` (a row
    /// from [`World::decode_pvs`] or [`World::decode_phs`]). Conservative: an open leaf without
    /// a cluster, or with a cluster beyond `row`, counts as visible.
    pub fn box_in_row(&self, row: &Bitset, a: impl Into<Vec3A>, b: impl Into<Vec3A>) -> bool {
        let (c, e) = center_extent(a.into(), b.into());
        descend(self.tree(), self.tree().root, c, e, &mut |_, cluster| {
            usize::try_from(cluster).map_or(true, |k| k >= row.len() || row.get(k))
        })
    }

    /// Drop from `faces` (face indices, as [`crate::Visible::faces`]) every face whose plane
    /// faces away from `eye` by more than [`BACKFACE_EPSILON`]; keeps the order and the faces out
    /// of range (the engine decides about those). The walk applies the same rule as it outputs
    /// faces when [`crate::View::cull_back_faces`] is set, which saves this pass.
    pub fn cull_back_faces(&self, eye: impl Into<Vec3A>, faces: &mut Vec<u32>) {
        let eye = eye.into();
        let draw = self.draw();
        faces.retain(|&f| front_or_near(draw, f, eye));
    }

    /// True when the box from `a` to `b` is potentially visible from `eye`: [`World::box_in_row`]
    /// with the PVS row of the eye's cluster, decoded into `row` (an eye in solid or outside the
    /// world sees everything, as in Quake).
    pub fn box_potentially_visible(
        &self,
        eye: impl Into<Vec3A>,
        a: impl Into<Vec3A>,
        b: impl Into<Vec3A>,
        row: &mut Bitset,
    ) -> bool {
        let cluster = self.leaf_cluster(self.leaf_at(eye)).unwrap_or(u32::MAX);
        self.decode_pvs(cluster, row);
        self.box_in_row(row, a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use sightline_tests::synth::grid_level;

    /// 6×5×3 cells of 64 units with about a quarter solid: every leaf's box is its cell.
    fn world(seed: u64) -> World {
        let mut rng = crate::poses::SplitMix64::new(seed);
        let solid: Vec<bool> = (0..6 * 5 * 3).map(|_| rng.below(4) == 0).collect();
        World::new(&grid_level([6, 5, 3], 64.0, true, |x, y, z| solid[(z * 5 + y) * 6 + x])).expect("valid")
    }

    fn meets(world: &World, leaf: LeafId, a: Vec3A, b: Vec3A, slack: f32) -> bool {
        let l = world.leaf_bounds(leaf).expect("leaf");
        (l.mins().cmple(b + slack) & l.maxs().cmpge(a - slack)).all()
    }

    proptest! {
        /// On a grid the brute force is exact: the reported leaves are every open cell the
        /// closed box meets, and (inside the grid) none farther than the epsilon.
        #[test]
        fn leaves_touching_equals_the_cells_the_box_meets(
            seed in 0u64..4,
            c in prop::array::uniform3(-40.0f32..430.0),
            h in prop::array::uniform3(0.0f32..100.0),
            snap in any::<bool>(),
        ) {
            let world = world(seed);
            let (mut a, mut b) = (Vec3A::from(c) - Vec3A::from(h), Vec3A::from(c) + Vec3A::from(h));
            if snap {
                // Faces exactly on cell planes.
                a = (a / 64.0).round() * 64.0;
                b = (b / 64.0).round() * 64.0;
            }
            let mut out = Vec::new();
            world.leaves_touching(b, a, &mut out);
            for &l in world.open_leaves() {
                if meets(&world, l, a, b, 0.0) {
                    prop_assert!(out.contains(&l), "leaf {} missing", l);
                }
            }
            // Cells at the border own the space beyond the grid, so only a box inside the grid
            // must stay near the cells it meets.
            let inside = a.cmpge(Vec3A::ZERO).all() && b.cmple(Vec3A::new(384.0, 320.0, 192.0)).all();
            for &l in &out {
                prop_assert!(world.leaf_contents(l).is_some_and(|c| c.is_open()));
                prop_assert!(!inside || meets(&world, l, a, b, 2.0 * BOX_EPSILON), "leaf {} too far", l);
            }
        }
    }

    #[test]
    fn a_box_is_visible_only_through_the_clusters_of_the_row() {
        let world = world(1);
        let leaf = world.open_leaves()[3];
        let cluster = world.leaf_cluster(leaf).expect("cluster");
        let cell = world.leaf_bounds(leaf).expect("leaf");
        let (a, b) = (cell.center - 8.0, cell.center + 8.0);
        let mut row = crate::pvs::Bitset::new(world.num_clusters() as usize);
        assert!(!world.box_in_row(&row, a, b), "empty row");
        row.set(cluster as usize);
        assert!(world.box_in_row(&row, a, b));
        // A box over a neighbour as well: visible through either cluster.
        let wide = (cell.mins() - 8.0, cell.maxs() + 8.0);
        let mut touched = Vec::new();
        world.leaves_touching(wide.0, wide.1, &mut touched);
        assert!(touched.len() > 1);
        let other = touched.iter().find(|&&l| l != leaf).and_then(|&l| world.leaf_cluster(l)).expect("other");
        let mut only_other = crate::pvs::Bitset::new(world.num_clusters() as usize);
        only_other.set(other as usize);
        assert!(world.box_in_row(&only_other, wide.0, wide.1));
        assert!(!world.box_in_row(&only_other, a, b));
        // A NaN box reaches every open leaf: conservative.
        world.leaves_touching(Vec3A::splat(f32::NAN), b, &mut touched);
        assert_eq!(touched.len(), world.open_leaves().len());
        // The eye in solid or outside sees everything (the grid's rows hold every cluster too).
        assert!(world.box_potentially_visible(Vec3A::splat(-1000.0), a, b, &mut row));
    }

    #[test]
    fn back_faces_are_dropped_and_faces_on_the_eye_plane_kept() {
        let world = world(2);
        let leaf = world.open_leaves()[0];
        let cell = world.leaf_bounds(leaf).expect("leaf");
        let all: Vec<u32> = (0..world.draw().num_faces() as u32).collect();
        let mut kept = all.clone();
        world.cull_back_faces(cell.center, &mut kept);
        // Faces of the eye's own cell face it; some faces of the level face away.
        assert!(world.leaf_faces(leaf).iter().all(|f| kept.contains(f)));
        assert!(kept.len() < all.len());
        for &f in &all {
            let (n, d) = world.draw().face_plane(f).expect("face");
            assert_eq!(kept.contains(&f), n.dot(cell.center) - d >= -BACKFACE_EPSILON, "face {f}");
            // An eye on the plane, or just behind it within the epsilon, keeps the face.
            let on = cell.center - n * (n.dot(cell.center) - d + BACKFACE_EPSILON * 0.5);
            let mut one = vec![f];
            world.cull_back_faces(on, &mut one);
            assert_eq!(one, vec![f], "face {f} from its plane");
        }
    }
}
