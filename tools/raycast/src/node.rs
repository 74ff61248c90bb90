//! The tree's storage: the binary nodes, the 4-wide traversal nodes and the leaves' triangle
//! blocks.

use glam::{Vec3, Vec4};

/// A node while building: a box, then either the first child (interior, `count == 0`; the second
/// child is `first + 1`) or the first triangle of a leaf (`count > 0`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct BuildNode {
    pub(crate) min: Vec3,
    pub(crate) first: u32,
    pub(crate) max: Vec3,
    pub(crate) count: u32,
}

/// A node as traversed: 32 bytes, two SIMD lanes sets; the `w` lanes carry the bits of `first`
/// (in `lo`) and `count` (in `hi`), as in [`BuildNode`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Node {
    pub(crate) lo: Vec4,
    pub(crate) hi: Vec4,
}

impl Node {
    pub(crate) fn pack(b: &BuildNode) -> Node {
        Node { lo: b.min.extend(f32::from_bits(b.first)), hi: b.max.extend(f32::from_bits(b.count)) }
    }

    #[inline(always)]
    pub(crate) fn first(&self) -> u32 {
        self.lo.w.to_bits()
    }

    #[inline(always)]
    pub(crate) fn count(&self) -> u32 {
        self.hi.w.to_bits()
    }
}

/// What traversal needs of up to four children of a node of the 4-wide traversal tree (the binary
/// tree collapsed: a node's children are replaced by theirs, largest surface area first, until it
/// has four), in two 64-byte cache lines. Boxes are stored one plane per vector with one lane per
/// child, so one SIMD slab test covers all four; unused lanes hold the empty box (min +∞, max −∞),
/// which no ray enters. A child is a quad (`count == 0`, `first` is its index in `quads`) or a
/// leaf (`first` is its first [`Block`], `count` its triangles).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Quad {
    /// `[min x, max x, min y, max y, min z, max z]`, lane `i` for child `i`.
    pub(crate) planes: [Vec4; 6],
    pub(crate) first: [u32; 4],
    pub(crate) count: [u32; 4],
}

impl Quad {
    pub(crate) const EMPTY: Quad = Quad {
        planes: [
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
        ],
        first: [0; 4],
        count: [0; 4],
    };
}

/// A triangle's corners, exactly as given (watertightness needs shared corners bit-identical).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Prepared {
    pub(crate) v0: Vec3,
    pub(crate) v1: Vec3,
    pub(crate) v2: Vec3,
}

/// Up to four triangles of a leaf, for one SIMD watertight test: `p[vertex][axis]`, lane `i` for
/// the `i`-th of the triangles at build positions `first..first + n` (as in `Bvh::ids`); unused
/// lanes are NaN, which never hits.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub(crate) struct Block {
    pub(crate) p: [[Vec4; 3]; 3],
    pub(crate) first: u32,
    pub(crate) n: u32,
}

impl Block {
    /// The blocks of the triangles `first..first + count` of `tris`.
    pub(crate) fn of_leaf(tris: &[Prepared], first: u32, count: u32) -> impl Iterator<Item = Block> + '_ {
        (first..first + count).step_by(4).map(move |f| {
            let n = (first + count - f).min(4);
            let mut p = [[Vec4::NAN; 3]; 3];
            for lane in 0..n as usize {
                let t = &tris[f as usize + lane];
                for (k, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                    for axis in 0..3 {
                        p[k][axis][lane] = v[axis];
                    }
                }
            }
            Block { p, first: f, n }
        })
    }

    /// The triangle in `lane`.
    pub(crate) fn tri(&self, lane: usize) -> Prepared {
        let v = |k: usize| Vec3::new(self.p[k][0][lane], self.p[k][1][lane], self.p[k][2][lane]);
        Prepared { v0: v(0), v1: v(1), v2: v(2) }
    }
}
