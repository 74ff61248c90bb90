//! PVS rows: a small bitset, decoding of a cluster's Quake-RLE row into it, and the PVS of every
//! cluster turned once at load into a pruned tree for the walk ([`ClusterTrees`]).

use sightline_formats::bits;

use crate::layout::{MarkSet, WalkTree};
use crate::world::World;

/// Most memory spent on the per-cluster PVS trees ([`ClusterTrees`]): 64 MiB. E1M1 needs about
/// 4.4 MiB (1,354 clusters × 164 branch nodes × 20 bytes); a level over the budget decodes its
/// row and marks the tree when the eye changes cluster.
pub const CLUSTER_TREE_BUDGET: usize = 64 << 20;

/// A node of a cluster's PVS tree: a node of the world tree with a potentially visible leaf on
/// **both** sides. Chains of nodes with only one marked side are skipped: they decide no order,
/// and their boxes contain the box of the next branch node or leaf, which is tested instead.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BranchNode {
    /// Index in the walk tree's nodes (for the plane).
    pub node: u32,
    /// Element of each child (for its box in `WalkTree::elem_box`).
    pub child_elem: [u32; 2],
    /// `>= 0`: index in [`ClusterTrees::nodes`]; `< 0`: `!index` in the walk tree's leaves.
    pub child: [i32; 2],
}

/// Every cluster's PVS precomputed at load as a pruned tree ([`BranchNode`]): the PVS backend
/// does no per-frame decoding or marking, and its walk visits only branch nodes and leaves.
#[derive(Debug, Clone, Default)]
pub(crate) struct ClusterTrees {
    pub nodes: Vec<BranchNode>,
    /// Per cluster: root as a child code (`None` when its PVS has no leaf), its element, and the
    /// number of leaves in the PVS.
    pub roots: Vec<(Option<(i32, u32)>, u32)>,
    /// Per cluster and one past the last: first of its (contiguous) nodes.
    pub starts: Vec<u32>,
}

impl ClusterTrees {
    /// Build the trees of `world`, or `None` without vis or over [`CLUSTER_TREE_BUDGET`].
    pub fn build(world: &World) -> Option<Self> {
        if !world.has_vis() {
            return None;
        }
        let tree = &world.tree;
        let clusters = world.num_clusters as usize;
        let mut row = Bitset::new(clusters);
        let mut marks = vec![0u32; tree.mark_slots()];
        let mut out =
            ClusterTrees { nodes: Vec::new(), roots: Vec::with_capacity(clusters), starts: vec![0] };
        let max_nodes = CLUSTER_TREE_BUDGET / std::mem::size_of::<BranchNode>();
        for c in 0..clusters {
            // A generation per cluster: no clearing between clusters.
            let gen_ = c as u32 + 1;
            world.decode_pvs(c as u32, &mut row);
            let mut leaves = 0;
            for visible in row.iter_ones() {
                for &e in world.cluster_elements(visible as u32) {
                    tree.mark_element(&mut marks, gen_, e);
                    leaves += 1;
                }
            }
            let set = MarkSet { marks: &marks, gen_ };
            let root = if set.contains(tree.root_bit) {
                Some(out.prune(tree, set, tree.root, tree.root_bit, max_nodes)?)
            } else {
                None
            };
            out.roots.push((root, leaves));
            out.starts.push(out.nodes.len() as u32);
        }
        Some(out)
    }

    /// The branch tree below walk-tree child `code` (element `elem`, marked), as (child code in
    /// the pruned tree, its element); `None` when the node budget runs out.
    fn prune(
        &mut self,
        tree: &WalkTree,
        set: MarkSet,
        code: i32,
        elem: u32,
        max: usize,
    ) -> Option<(i32, u32)> {
        let mut code = code;
        let mut elem = elem;
        // Follow single-marked chains down to a leaf or a branch node.
        loop {
            if code < 0 {
                return Some((code, elem));
            }
            let node = tree.nodes.get(code as usize)?;
            let marked = node.child_bit.map(|b| set.contains(b));
            match marked {
                [true, true] => break,
                [true, false] => (code, elem) = (node.child[0], node.child_bit[0]),
                [false, true] => (code, elem) = (node.child[1], node.child_bit[1]),
                [false, false] => return None,
            }
        }
        let node = *tree.nodes.get(code as usize)?;
        if self.nodes.len() >= max {
            return None;
        }
        let index = self.nodes.len();
        self.nodes.push(BranchNode { node: code as u32, child_elem: [0; 2], child: [0; 2] });
        for k in 0..2 {
            let (c, e) = self.prune(tree, set, node.child[k], node.child_bit[k], max)?;
            let b = self.nodes.get_mut(index)?;
            b.child[k] = c;
            b.child_elem[k] = e;
        }
        Some((index as i32, elem))
    }

    /// The nodes of `cluster`'s tree.
    #[inline]
    pub fn cluster_nodes(&self, cluster: u32) -> &[BranchNode] {
        let c = cluster as usize;
        match (self.starts.get(c), self.starts.get(c + 1)) {
            (Some(&a), Some(&b)) => self.nodes.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Root (child code, element) and PVS leaf count of `cluster`.
    #[inline]
    pub fn root(&self, cluster: u32) -> Option<(Option<(i32, u32)>, u32)> {
        self.roots.get(cluster as usize).copied()
    }
}

/// A fixed-length set of bits, owned by the caller and reused across calls.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Bitset {
    words: Vec<u64>,
    len: usize,
}

impl Bitset {
    /// `len` bits, all clear.
    pub fn new(len: usize) -> Self {
        Self { words: vec![0; bits::words(len)], len }
    }

    /// Number of bits.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True for a zero-length set.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Change the length to `len` bits, all clear (allocates only when growing past capacity).
    pub fn reset(&mut self, len: usize) {
        self.words.clear();
        self.words.resize(bits::words(len), 0);
        self.len = len;
    }

    /// Bit `i` (false when out of range).
    #[inline]
    pub fn get(&self, i: usize) -> bool {
        bits::get(&self.words, i)
    }

    /// Set bit `i` (ignored when out of range).
    #[inline]
    pub fn set(&mut self, i: usize) {
        if i < self.len {
            bits::set(&mut self.words, i);
        }
    }

    /// Set every bit.
    pub fn fill(&mut self) {
        self.words.fill(u64::MAX);
        self.trim();
    }

    /// Number of set bits.
    pub fn count_ones(&self) -> usize {
        bits::count(&self.words) as usize
    }

    /// Indices of set bits, ascending.
    pub fn iter_ones(&self) -> impl Iterator<Item = usize> + '_ {
        bits::ones(&self.words)
    }

    /// The 64-bit words, bit `i` in word `i / 64`, bit `i % 64`.
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    fn trim(&mut self) {
        let extra = self.words.len() * 64 - self.len;
        if extra > 0
            && let Some(last) = self.words.last_mut()
        {
            *last &= u64::MAX >> extra;
        }
    }
}

impl World {
    /// Decode the PVS row of `cluster` into `out` (resized to [`World::num_clusters`] bits; bit `j`
    /// set means cluster `j` is potentially visible). Without vis data, or for a cluster out of
    /// range (the eye in solid), every bit is set, as Quake does.
    pub fn decode_pvs(&self, cluster: u32, out: &mut Bitset) {
        out.reset(self.num_clusters as usize);
        let Some(&offset) = self.pvs_offsets.get(cluster as usize) else {
            out.fill();
            return;
        };
        let data = self.pvs_data.get(offset as usize..).unwrap_or(&[]);
        let mut pos = 0;
        let mut byte = 0;
        while byte < self.row_bytes {
            let Some(&b) = data.get(pos) else { break };
            if b != 0 {
                if let Some(w) = out.words.get_mut(byte >> 3) {
                    *w |= u64::from(b) << ((byte & 7) * 8);
                }
                byte += 1;
                pos += 1;
            } else {
                byte += usize::from(data.get(pos + 1).copied().unwrap_or(u8::MAX));
                pos += 2;
            }
        }
        out.trim();
    }
}
