//! The node, leaf and model bounds compiled maps store, made fit for use in a [`Level`].
//!
//! Nothing in a compiled map depends on its stored bounds, and compilers do not always write
//! usable ones: ericw-tools' qbsp has written `±inf` on the world model, on nodes and on a leaf of
//! a BSP2 file that its vis and every engine read; q3map2 stores `INT_MAX..INT_MIN` on a leaf no
//! node names. So the readers ([`super::read`], [`super::q2::read`], [`super::q3::read`]) accept
//! any bounds, and the conversion to a level ([`super::to_level`], [`super::q2::to_level`],
//! [`super::q3::to_level`], [`super::CompiledMap::to_level`]) replaces every box that is not
//! [`usable`] by one that holds what the record covers, never a smaller one:
//! - a **leaf**: the extent of the whole map ([`map_extent`]: every face corner and every usable
//!   stored box), which holds every leaf of a sealed map and every leaf whose own or ancestors'
//!   stored boxes are usable;
//! - a **node**: the union of its children's boxes (after their own repair);
//! - a **model**: the box of its faces' corners, or the map's extent for a model without faces.
//!
//! What uses a level's boxes: the runtime culls open leaves by their boxes and draws brush models
//! by theirs; validation samples open leaves inside theirs; `info` prints the world model's. A
//! repair of such a box (an open leaf's or a model's) is reported as a [`BoundsRepair`], for the
//! caller to show as a warning. Node boxes and solid leaves' boxes are used by nothing that reads
//! a level (the runtime recomputes node boxes from the open leaves below), so their repair is
//! silent.

use std::fmt;

use crate::geom::WORLD_LIMIT;
use crate::level::Level;

/// True when `mins..maxs` is a box code may use: every coordinate finite and `mins <= maxs` on
/// every axis. The one test of stored bounds (the readers, the conversion to a level and the
/// drop-in vis's far plane and portal box all ask it).
pub fn usable(mins: [f32; 3], maxs: [f32; 3]) -> bool {
    (0..3).all(|k| mins[k].is_finite() && maxs[k].is_finite() && mins[k] <= maxs[k])
}

/// Boxes of one kind of record that the conversion to a level replaced and something uses (see the
/// module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoundsRepair {
    /// `"leaf"` (open leaves only) or `"model"`.
    pub record: &'static str,
    /// Their indices, in the file and in the level alike, ascending.
    pub indices: Vec<u32>,
    /// What now stands in for their bounds.
    pub stand_in: &'static str,
}

/// How many indices a [`BoundsRepair`] names in its message.
const NAMED: usize = 5;

impl fmt::Display for BoundsRepair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (record, stand_in) = (self.record, self.stand_in);
        if let [i] = self.indices[..] {
            return write!(f, "{record} {i}: bounds not finite or inverted; {stand_in}");
        }
        let named: Vec<String> = self.indices.iter().take(NAMED).map(u32::to_string).collect();
        let more = if self.indices.len() > NAMED { ", ..." } else { "" };
        let plural = if record == "leaf" { "leaves" } else { "models" };
        let n = self.indices.len();
        write!(f, "{n} {plural} ({}{more}): bounds not finite or inverted; {stand_in}", named.join(", "))
    }
}

const LEAF_STAND_IN: &str = "the whole map's extent stands in";
const MODEL_STAND_IN: &str = "recomputed from its faces (the map's extent for a model without faces)";

/// The box holding every corner of the level and every [`usable`] stored box: the extent of the
/// whole map. `±`[`WORLD_LIMIT`] when the level has neither.
pub fn map_extent(level: &Level) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut add = |mins: [f32; 3], maxs: [f32; 3]| {
        if usable(mins, maxs) {
            for k in 0..3 {
                lo[k] = lo[k].min(mins[k]);
                hi[k] = hi[k].max(maxs[k]);
            }
        }
    };
    level.vertices.iter().for_each(|&v| add(v, v));
    level.nodes.iter().for_each(|n| add(n.mins, n.maxs));
    level.leaves.iter().for_each(|l| add(l.mins, l.maxs));
    level.models.iter().for_each(|m| add(m.mins, m.maxs));
    if usable(lo, hi) {
        (lo, hi)
    } else {
        let limit = WORLD_LIMIT as f32;
        ([-limit; 3], [limit; 3])
    }
}

/// Replaces every box of `level` that is not [`usable`] (see the module docs); returns the
/// repairs of boxes something uses, leaves first. Node children must be in range and acyclic
/// (every reader checks that before a level is made).
pub(crate) fn repair(level: &mut Level) -> Vec<BoundsRepair> {
    let bad_leaves: Vec<usize> =
        (0..level.leaves.len()).filter(|&i| !usable(level.leaves[i].mins, level.leaves[i].maxs)).collect();
    let bad_nodes = level.nodes.iter().filter(|n| !usable(n.mins, n.maxs)).count();
    let bad_models: Vec<usize> =
        (0..level.models.len()).filter(|&i| !usable(level.models[i].mins, level.models[i].maxs)).collect();
    if bad_leaves.is_empty() && bad_nodes == 0 && bad_models.is_empty() {
        return Vec::new();
    }
    let extent = map_extent(level);
    for &i in &bad_leaves {
        (level.leaves[i].mins, level.leaves[i].maxs) = extent;
    }
    if bad_nodes > 0 {
        repair_nodes(level, extent);
    }
    for &i in &bad_models {
        let m = level.models[i];
        let first = m.first_face as usize;
        let faces = level.faces.get(first..first.saturating_add(m.num_faces as usize)).unwrap_or_default();
        let mut corners = faces.iter().flat_map(|f| {
            let v0 = f.first_vertex as usize;
            level.vertices.get(v0..v0.saturating_add(f.num_vertices as usize)).unwrap_or_default()
        });
        let boxed = corners.next().map(|&first| {
            corners.fold((first, first), |(lo, hi), v| {
                (std::array::from_fn(|k| lo[k].min(v[k])), std::array::from_fn(|k| hi[k].max(v[k])))
            })
        });
        let model = &mut level.models[i];
        (model.mins, model.maxs) = boxed.filter(|&(lo, hi)| usable(lo, hi)).unwrap_or(extent);
    }
    let mut out = Vec::new();
    let open: Vec<u32> =
        bad_leaves.iter().filter(|&&i| level.leaves[i].contents.is_open()).map(|&i| i as u32).collect();
    if !open.is_empty() {
        out.push(BoundsRepair { record: "leaf", indices: open, stand_in: LEAF_STAND_IN });
    }
    if !bad_models.is_empty() {
        let indices = bad_models.iter().map(|&i| i as u32).collect();
        out.push(BoundsRepair { record: "model", indices, stand_in: MODEL_STAND_IN });
    }
    out
}

/// Every node box that is not [`usable`] becomes the union of its children's boxes, children
/// first (an explicit stack: the node graph is acyclic but may be deep). Leaves are already
/// repaired; a child out of range (impossible after the readers' checks) counts as `extent`.
fn repair_nodes(level: &mut Level, extent: ([f32; 3], [f32; 3])) {
    let n = level.nodes.len();
    // 0: not visited, 1: children pushed, 2: done (box usable).
    let mut state: Vec<u8> =
        level.nodes.iter().map(|node| if usable(node.mins, node.maxs) { 2 } else { 0 }).collect();
    let child_box = |level: &Level, c: i32| -> ([f32; 3], [f32; 3]) {
        match usize::try_from(c) {
            Ok(i) => level.nodes.get(i).map_or(extent, |n| (n.mins, n.maxs)),
            Err(_) => {
                let leaf = usize::try_from(-(i64::from(c) + 1)).ok().and_then(|l| level.leaves.get(l));
                leaf.map_or(extent, |l| (l.mins, l.maxs))
            }
        }
    };
    let mut stack = Vec::new();
    for start in 0..n {
        if state[start] == 2 {
            continue;
        }
        stack.push(start);
        while let Some(&i) = stack.last() {
            if state[i] == 0 {
                state[i] = 1;
                for c in level.nodes[i].children {
                    if let Some(c) = usize::try_from(c).ok().filter(|&c| c < n && state[c] == 0) {
                        stack.push(c);
                    }
                }
                continue;
            }
            stack.pop();
            if state[i] == 2 {
                continue;
            }
            let [a, b] = level.nodes[i].children.map(|c| child_box(level, c));
            let lo = std::array::from_fn(|k| a.0[k].min(b.0[k]));
            let hi = std::array::from_fn(|k| a.1[k].max(b.1[k]));
            let (lo, hi) = if usable(lo, hi) { (lo, hi) } else { extent };
            (level.nodes[i].mins, level.nodes[i].maxs) = (lo, hi);
            state[i] = 2;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::level::{Contents, Face, Leaf, Model, Node};

    fn leaf(contents: Contents, mins: [f32; 3], maxs: [f32; 3]) -> Leaf {
        Leaf { contents, cluster: -1, mins, maxs, first_face: 0, num_faces: 0 }
    }

    /// Node 0 splits node 1 (two open leaves) from solid leaf 0; one face over the open leaves.
    fn level() -> Level {
        let node = |children, mins, maxs| Node { plane: 0, children, mins, maxs };
        Level {
            nodes: vec![node([1, -1], [0.0; 3], [64.0; 3]), node([-2, -3], [0.0; 3], [64.0; 3])],
            leaves: vec![
                leaf(Contents::Solid, [0.0; 3], [0.0; 3]),
                leaf(Contents::Empty, [0.0; 3], [32.0, 64.0, 64.0]),
                leaf(Contents::Empty, [32.0, 0.0, 0.0], [64.0; 3]),
            ],
            vertices: vec![[0.0, 0.0, 0.0], [64.0, 0.0, 0.0], [64.0, 64.0, 8.0]],
            faces: vec![Face { plane: 0, first_vertex: 0, num_vertices: 3, texture: 0 }],
            models: vec![Model {
                head_node: 0,
                mins: [0.0; 3],
                maxs: [64.0; 3],
                first_face: 0,
                num_faces: 1,
            }],
            ..Level::default()
        }
    }

    #[test]
    fn usable_boxes_are_finite_and_not_inverted() {
        assert!(usable([0.0; 3], [0.0; 3]));
        assert!(usable([-1.0, 2.0, 3.0], [1.0, 2.0, 4.0]));
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            for k in 0..3 {
                let mut mins = [0.0; 3];
                mins[k] = bad;
                assert!(!usable(mins, [1.0; 3]) && !usable([-1.0; 3], mins.map(|v| -v)), "{bad} on axis {k}");
            }
        }
        assert!(!usable([1.0, 0.0, 0.0], [0.0, 5.0, 5.0]), "inverted on one axis");
    }

    #[test]
    fn usable_bounds_are_kept_and_nothing_is_reported() {
        let mut l = level();
        assert_eq!(repair(&mut l), []);
        assert_eq!(l, level());
    }

    #[test]
    fn every_unusable_box_is_replaced_by_one_holding_what_it_covers() {
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            let mut l = level();
            l.leaves[2].maxs[1] = bad;
            l.leaves[0].mins = [bad; 3];
            l.nodes[1].mins[0] = bad;
            l.nodes[0].maxs = [-bad; 3];
            l.models[0].mins[2] = bad;
            let repairs = repair(&mut l);
            let (lo, hi) = ([0.0; 3], [64.0; 3]);
            // The open leaf and the model are reported; the solid leaf and the nodes are not.
            assert_eq!(
                repairs.iter().map(|r| (r.record, r.indices.clone())).collect::<Vec<_>>(),
                [("leaf", vec![2]), ("model", vec![0])]
            );
            assert_eq!((l.leaves[2].mins, l.leaves[2].maxs), (lo, hi), "the map's extent");
            assert_eq!((l.leaves[0].mins, l.leaves[0].maxs), (lo, hi));
            assert_eq!((l.nodes[1].mins, l.nodes[1].maxs), (lo, hi), "union of its leaves");
            assert_eq!((l.nodes[0].mins, l.nodes[0].maxs), (lo, hi), "union of node 1 and leaf 0");
            assert_eq!((l.models[0].mins, l.models[0].maxs), ([0.0; 3], [64.0, 64.0, 8.0]), "its face");
            assert!(l.nodes.iter().all(|n| usable(n.mins, n.maxs)));
        }
        // A node whose children are usable gets exactly their union.
        let mut l = level();
        l.nodes[1].maxs = [f32::NAN; 3];
        assert_eq!(repair(&mut l), []);
        assert_eq!((l.nodes[1].mins, l.nodes[1].maxs), ([0.0; 3], [64.0; 3]));
        // A model without faces, and a level with nothing usable at all.
        let mut l = level();
        l.models[0] = Model { num_faces: 0, mins: [f32::NAN; 3], ..l.models[0] };
        l.vertices.clear();
        for x in &mut l.leaves {
            x.mins = [1.0; 3];
            x.maxs = [-1.0; 3];
        }
        l.nodes.iter_mut().for_each(|n| n.mins = [f32::INFINITY; 3]);
        let repairs = repair(&mut l);
        assert_eq!(repairs[0].indices, [1, 2]);
        let limit = WORLD_LIMIT as f32;
        assert_eq!((l.models[0].mins, l.models[0].maxs), ([-limit; 3], [limit; 3]));
        assert!(l.leaves.iter().all(|x| x.mins == [-limit; 3] && x.maxs == [limit; 3]));
    }

    #[test]
    fn repairs_read_as_warnings() {
        let r = BoundsRepair { record: "leaf", indices: (3..10).collect(), stand_in: LEAF_STAND_IN };
        assert_eq!(
            r.to_string(),
            format!("7 leaves (3, 4, 5, 6, 7, ...): bounds not finite or inverted; {LEAF_STAND_IN}")
        );
        let r = BoundsRepair { record: "model", indices: vec![0], stand_in: MODEL_STAND_IN };
        assert_eq!(r.to_string(), format!("model 0: bounds not finite or inverted; {MODEL_STAND_IN}"));
    }
}
