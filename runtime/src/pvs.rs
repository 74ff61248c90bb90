//! PVS rows: a small bitset ([`Bitset`]), the level's compressed rows (`PvsRows`, decoded with
//! [`sightline_formats::rle`] straight into a bitset), and the PVS of every cluster turned once at
//! load into a pruned tree for the walk (`ClusterTrees`).
//!
//! This module sits below [`crate::world`], which owns the rows and the trees.

use sightline_formats::level::Level;
use sightline_formats::{bits, rle};

use crate::layout::{MarkSet, WalkTree};
use crate::tree::Csr;

/// Most memory spent on the per-cluster PVS trees (`ClusterTrees`): 64 MiB. E1M1 needs about
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
    /// Build the trees of every cluster of `rows` over the walk layout `tree`, where
    /// `cluster_elems` lists the walk-tree elements of each cluster's leaves; `None` without vis
    /// or over [`CLUSTER_TREE_BUDGET`].
    pub fn build(tree: &WalkTree, rows: &PvsRows, cluster_elems: &Csr) -> Option<Self> {
        if !rows.has_vis() {
            return None;
        }
        let clusters = rows.num_clusters as usize;
        let mut row = Bitset::new(clusters);
        let mut marks = vec![0u32; tree.mark_slots()];
        let mut out =
            ClusterTrees { nodes: Vec::new(), roots: Vec::with_capacity(clusters), starts: vec![0] };
        let max_nodes = CLUSTER_TREE_BUDGET / std::mem::size_of::<BranchNode>();
        for c in 0..clusters {
            // A generation per cluster: no clearing between clusters.
            let gen_ = c as u32 + 1;
            rows.decode(c as u32, &mut row);
            let mut leaves = 0;
            for visible in row.iter_ones() {
                for &e in cluster_elems.get(visible) {
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

    /// Clear the bits past `len` in the last word.
    fn trim(&mut self) {
        let len = self.len;
        if let Some((w, last)) = self.words.iter_mut().enumerate().next_back() {
            *last &= bits::valid_mask(w, len);
        }
    }
}

/// The level's PVS: one Quake-RLE row per cluster (see [`sightline_formats::level`]). Made from a
/// level that passed [`sightline_formats::slvl::validate`], so every row decodes.
#[derive(Debug, Clone, Default)]
pub(crate) struct PvsRows {
    num_clusters: u32,
    row_bytes: usize,
    /// Empty without vis.
    offsets: Vec<u32>,
    data: Vec<u8>,
}

impl PvsRows {
    /// The rows of `level` (validated: one decodable row per cluster, or none).
    pub fn new(level: &Level) -> Self {
        let vis = level.has_vis();
        Self {
            num_clusters: level.num_clusters,
            row_bytes: level.row_bytes(),
            offsets: if vis { level.pvs_offsets.clone() } else { Vec::new() },
            data: if vis { level.pvs_data.clone() } else { Vec::new() },
        }
    }

    /// Rows of `num_clusters` bits at `offsets` (one per cluster, or none: no vis) in `data`,
    /// each already checked to decode (as [`sightline_formats::bsp::q2::read`] checks a Quake 2
    /// visibility lump's rows).
    pub fn from_parts(num_clusters: u32, offsets: Vec<u32>, data: Vec<u8>) -> Self {
        Self { num_clusters, row_bytes: bits::bytes::len(num_clusters as usize), offsets, data }
    }

    /// True when the level carries a PVS.
    pub fn has_vis(&self) -> bool {
        !self.offsets.is_empty()
    }

    /// Decode the row of `cluster` into `out` (resized to the cluster count; bit `j` set means
    /// cluster `j` is potentially visible). Without vis, for a cluster out of range (the eye in
    /// solid), or for a row that does not decode (never, after validation), every bit is set.
    pub fn decode(&self, cluster: u32, out: &mut Bitset) {
        out.reset(self.num_clusters as usize);
        let Some(&offset) = self.offsets.get(cluster as usize) else {
            out.fill();
            return;
        };
        let data = self.data.get(offset as usize..).unwrap_or(&[]);
        match rle::decode_row_words(data, self.row_bytes, &mut out.words) {
            Ok(_) => out.trim(),
            Err(_) => out.fill(),
        }
    }
}

/// The PHS (potentially hearable set) of a Quake 1 level: row `c` is the union of the PVS rows of
/// every cluster in `c`'s PVS (Quake's `SV_CalcPHS`), and `c`'s own row, so anything a cluster could hear is in it.
/// Computed on first use (clients that never ask pay nothing) and kept compressed like the PVS.
/// A file that carries its own PHS (Quake 2's visibility lump) gives its rows instead: set the
/// lock from them at load ([`PhsRows::stored`]).
#[derive(Debug, Default)]
pub(crate) struct PhsRows {
    rows: std::sync::OnceLock<PvsRows>,
}

impl PhsRows {
    /// Rows a level stored for itself; `None` computes them from the PVS on first use.
    pub fn stored(rows: Option<PvsRows>) -> Self {
        let lock = std::sync::OnceLock::new();
        if let Some(rows) = rows {
            let _ = lock.set(rows);
        }
        Self { rows: lock }
    }

    /// Decode the PHS row of `cluster` into `out`, as [`PvsRows::decode`] does for the PVS.
    pub fn decode(&self, pvs: &PvsRows, cluster: u32, out: &mut Bitset) {
        self.rows.get_or_init(|| Self::compute(pvs)).decode(cluster, out);
    }

    /// Quake's union: for every cluster, OR the rows of the clusters its row holds. Every row is
    /// decoded once into a matrix of `clusters² / 8` bytes (Quake servers keep the PVS so), freed
    /// when the compressed PHS rows are made.
    fn compute(pvs: &PvsRows) -> PvsRows {
        if !pvs.has_vis() {
            return pvs.clone();
        }
        let n = pvs.num_clusters;
        let mut row = Bitset::default();
        let words = bits::words(n as usize);
        let mut matrix = Vec::with_capacity(words * n as usize);
        for c in 0..n {
            pvs.decode(c, &mut row);
            matrix.extend_from_slice(&row.words);
        }
        let mut acc = vec![0u64; words];
        let mut bytes = Vec::with_capacity(pvs.row_bytes + 8);
        let mut out =
            PvsRows { num_clusters: n, row_bytes: pvs.row_bytes, offsets: Vec::new(), data: Vec::new() };
        for own in matrix.chunks_exact(words.max(1)) {
            acc.copy_from_slice(own);
            for j in bits::ones(own) {
                for (a, o) in acc.iter_mut().zip(matrix.get(j * words..(j + 1) * words).unwrap_or(&[])) {
                    *a |= o;
                }
            }
            bytes.clear();
            bytes.extend(acc.iter().flat_map(|w| w.to_le_bytes()));
            bytes.truncate(pvs.row_bytes);
            out.offsets.push(out.data.len() as u32);
            rle::encode_row(&bytes, &mut out.data);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_job::rng::SplitMix64;

    #[test]
    fn decoded_rows_hold_the_bits_of_the_byte_rows() {
        let mut rng = SplitMix64::new(17);
        for clusters in [1u32, 7, 8, 63, 64, 65, 130, 700] {
            let mut level = Level { num_clusters: clusters, ..Level::default() };
            let mut rows = Vec::new();
            for _ in 0..clusters {
                let mut row = vec![0u8; level.row_bytes()];
                for b in &mut row {
                    *b = if rng.below(3) == 0 { rng.below(256) as u8 } else { 0 };
                }
                level.pvs_offsets.push(level.pvs_data.len() as u32);
                rle::encode_row(&row, &mut level.pvs_data);
                rows.push(row);
            }
            let pvs = PvsRows::new(&level);
            let mut set = Bitset::new(3);
            for (c, row) in rows.iter().enumerate() {
                pvs.decode(c as u32, &mut set);
                assert_eq!(set.len(), clusters as usize);
                for j in 0..clusters as usize + 9 {
                    let want = j < clusters as usize && bits::bytes::get(row, j);
                    assert_eq!(set.get(j), want, "{clusters} clusters, row {c}, bit {j}");
                }
                assert!(set.iter_ones().all(|j| j < clusters as usize));
            }
            // Out of range (the eye in solid): everything.
            pvs.decode(clusters, &mut set);
            assert_eq!(set.count_ones(), clusters as usize);
        }
    }
}
