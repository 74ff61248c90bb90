//! The level's BSP tree as the validator and the renderer walk it: point location and segment
//! traces, in `f64`, written here rather than borrowed from the runtime so that a bug in the
//! runtime's walk cannot hide a bug in a PVS.
//!
//! Conventions are the level's: a node's `children[0]` is the front (`normal · p - dist >= 0`), a
//! child `c < 0` is leaf `-(c + 1)`. A point exactly on a plane goes to the front, as in Quake.
//! "Solid" below means any leaf sight does not pass: [`Contents::Solid`] and [`Contents::Sky`].

use glam::DVec3;
use sightline_formats::{Contents, Level};

use crate::ValidateError;

/// True when sight passes through leaves of these contents: everything but solid and sky. Sky
/// blocks as it does in Quake's vis, which writes no portal between sky and other contents; a
/// validator that let rays through sky would report pairs no vis ever claims.
pub fn sight_passes(contents: Contents) -> bool {
    !matches!(contents, Contents::Solid | Contents::Sky)
}

/// A checked view of a level's world tree (model 0).
#[derive(Debug)]
pub struct BspTree<'a> {
    level: &'a Level,
    root: i32,
    /// Node planes converted once to `f64`: `(normal, dist)`.
    planes: Vec<(DVec3, f64)>,
    /// For every leaf, whether sight passes through it ([`sight_passes`]).
    open: Vec<bool>,
}

/// One open leaf crossed by a trace, over the parameter range `t0..t1` of the segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Leaf index.
    pub leaf: u32,
    /// Segment parameter where the trace enters the leaf.
    pub t0: f64,
    /// Segment parameter where the trace leaves it.
    pub t1: f64,
    /// Unit normal of the plane through which the trace enters the leaf, facing the segment's
    /// start (`-direction` for the leaf the segment starts in).
    pub normal: DVec3,
}

/// Where a trace stopped: the first solid leaf, entered at parameter `t` through a plane whose
/// normal, facing back towards the segment's start, is `normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Segment parameter of the entry into solid.
    pub t: f64,
    /// Unit normal of the entered surface, facing the start of the segment (`-direction` when
    /// the segment starts inside solid).
    pub normal: DVec3,
    /// The solid leaf entered.
    pub leaf: u32,
}

impl<'a> BspTree<'a> {
    /// Check every index reachable from the world root (children, planes, no cycles) so that the
    /// walks below cannot go out of range or loop.
    pub fn new(level: &'a Level) -> Result<Self, ValidateError> {
        let model = level.models.first().ok_or(ValidateError::NoWorldTree)?;
        let root = model.head_node;
        let planes: Vec<(DVec3, f64)> = level
            .planes
            .iter()
            .map(|p| (DVec3::new(p.normal[0] as f64, p.normal[1] as f64, p.normal[2] as f64), p.dist as f64))
            .collect();
        let mut seen = vec![false; level.nodes.len()];
        let mut stack = vec![root];
        while let Some(c) = stack.pop() {
            if c < 0 {
                let leaf = (-(c as i64) - 1) as usize;
                if leaf >= level.leaves.len() {
                    return Err(ValidateError::MissingLeaf { leaf, leaves: level.leaves.len() });
                }
                continue;
            }
            let n = c as usize;
            let node = level.nodes.get(n).ok_or(ValidateError::MissingNode { node: n })?;
            if std::mem::replace(&mut seen[n], true) {
                return Err(ValidateError::NodeReachedTwice { node: n });
            }
            if node.plane as usize >= planes.len() {
                return Err(ValidateError::MissingPlane { node: n, plane: node.plane });
            }
            stack.extend(node.children);
        }
        let open = level.leaves.iter().map(|l| sight_passes(l.contents)).collect();
        Ok(Self { level, root, planes, open })
    }

    /// The level behind the tree.
    pub fn level(&self) -> &'a Level {
        self.level
    }

    /// True when sight passes through `leaf` (see [`sight_passes`]).
    pub fn is_open(&self, leaf: usize) -> bool {
        self.open.get(leaf).copied().unwrap_or(false)
    }

    /// Cluster of `leaf`, `None` for solid leaves or leaves outside every cluster.
    pub fn cluster(&self, leaf: usize) -> Option<u32> {
        let l = self.level.leaves.get(leaf)?;
        if l.contents == Contents::Solid || l.cluster < 0 {
            return None;
        }
        Some(l.cluster as u32)
    }

    /// Plane `i` as `(normal, dist)`; `i` comes from a node checked in [`BspTree::new`].
    fn plane(&self, i: u32) -> (DVec3, f64) {
        self.planes[i as usize]
    }

    /// The leaf containing `p` (points on a plane go to its front).
    pub fn leaf_at(&self, p: DVec3) -> usize {
        let mut c = self.root;
        while c >= 0 {
            let node = &self.level.nodes[c as usize];
            let (n, d) = self.plane(node.plane);
            c = node.children[usize::from(n.dot(p) - d < 0.0)];
        }
        (-(c as i64) - 1) as usize
    }

    /// For every leaf, the node planes on the way from the root to it, each as the half-space
    /// `normal · p - dist >= 0` that contains the leaf; `None` for leaves the world tree does not
    /// reach (and for the solid leaf that several branches share, the last path found).
    pub fn leaf_half_spaces(&self) -> Vec<Option<Vec<(DVec3, f64)>>> {
        let mut out = vec![None; self.level.leaves.len()];
        let mut stack: Vec<(i32, Vec<(DVec3, f64)>)> = vec![(self.root, Vec::new())];
        while let Some((c, path)) = stack.pop() {
            if c < 0 {
                out[(-(c as i64) - 1) as usize] = Some(path);
                continue;
            }
            let node = &self.level.nodes[c as usize];
            let (n, d) = self.plane(node.plane);
            let mut front = path.clone();
            front.push((n, d));
            let mut back = path;
            back.push((-n, -d));
            stack.push((node.children[0], front));
            stack.push((node.children[1], back));
        }
        out
    }

    /// Walk the segment `a → b` front to back, appending every open leaf it crosses to `out`
    /// until it enters a solid leaf, which is returned (`None` when `b` is reached in the open).
    /// `stack` is scratch space, kept by the caller to avoid allocating per trace.
    pub fn trace(
        &self,
        a: DVec3,
        b: DVec3,
        out: &mut Vec<Crossing>,
        stack: &mut Vec<(i32, f64, f64, DVec3)>,
    ) -> Option<Hit> {
        self.walk(a, b, out, stack, false)
    }

    /// Like [`BspTree::trace`] but through solid leaves: every leaf on the whole segment, solid
    /// ones included, is appended in order, and the first solid leaf entered (if any) is returned.
    pub fn trace_through(
        &self,
        a: DVec3,
        b: DVec3,
        out: &mut Vec<Crossing>,
        stack: &mut Vec<(i32, f64, f64, DVec3)>,
    ) -> Option<Hit> {
        self.walk(a, b, out, stack, true)
    }

    fn walk(
        &self,
        a: DVec3,
        b: DVec3,
        out: &mut Vec<Crossing>,
        stack: &mut Vec<(i32, f64, f64, DVec3)>,
        through_solid: bool,
    ) -> Option<Hit> {
        let mut first_hit = None;
        let dir = b - a;
        stack.clear();
        let start_normal = -dir.normalize_or_zero();
        stack.push((self.root, 0.0, 1.0, start_normal));
        // Entries are pushed far side last-in-first-out, so popping visits near to far.
        while let Some((mut c, t0, mut t1, entry_normal)) = stack.pop() {
            loop {
                if c < 0 {
                    let leaf = (-(c as i64) - 1) as usize;
                    if !self.open[leaf] {
                        let hit = Hit { t: t0, normal: entry_normal, leaf: leaf as u32 };
                        if !through_solid {
                            return Some(hit);
                        }
                        first_hit.get_or_insert(hit);
                        out.push(Crossing { leaf: leaf as u32, t0, t1, normal: entry_normal });
                        break;
                    }
                    out.push(Crossing { leaf: leaf as u32, t0, t1, normal: entry_normal });
                    break;
                }
                let node = &self.level.nodes[c as usize];
                let (n, d) = self.plane(node.plane);
                let da = n.dot(a) - d;
                let db = n.dot(b) - d;
                let d0 = da + (db - da) * t0;
                let d1 = da + (db - da) * t1;
                if d0 >= 0.0 && d1 >= 0.0 {
                    c = node.children[0];
                    continue;
                }
                if d0 < 0.0 && d1 < 0.0 {
                    c = node.children[1];
                    continue;
                }
                let tm = (da / (da - db)).clamp(t0, t1);
                let (near, far, far_normal) = if d0 >= 0.0 {
                    (node.children[0], node.children[1], n)
                } else {
                    (node.children[1], node.children[0], -n)
                };
                stack.push((far, tm, t1, far_normal));
                c = near;
                t1 = tm;
            }
        }
        first_hit
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sightline_formats::{Leaf, LevelPlane, Model, Node};

    fn leaf(contents: Contents, cluster: i32, mins: [f32; 3], maxs: [f32; 3]) -> Leaf {
        Leaf { contents, cluster, mins, maxs, first_face: 0, num_faces: 0 }
    }

    /// A corridor along x: solid below x = 0, open cells [0,64), [64,128), solid wall at
    /// x in [128,136), open cell [136, 200), solid beyond x = 200; everything is 64 units high and
    /// wide (solid outside |y| < 32, 0 <= z < 64, found through extra planes).
    pub(crate) fn corridor() -> Level {
        let planes = vec![
            LevelPlane { normal: [1.0, 0.0, 0.0], dist: 0.0 },
            LevelPlane { normal: [1.0, 0.0, 0.0], dist: 64.0 },
            LevelPlane { normal: [1.0, 0.0, 0.0], dist: 128.0 },
            LevelPlane { normal: [1.0, 0.0, 0.0], dist: 136.0 },
            LevelPlane { normal: [1.0, 0.0, 0.0], dist: 200.0 },
            LevelPlane { normal: [0.0, 1.0, 0.0], dist: 32.0 },
            LevelPlane { normal: [0.0, 1.0, 0.0], dist: -32.0 },
            LevelPlane { normal: [0.0, 0.0, 1.0], dist: 64.0 },
            LevelPlane { normal: [0.0, 0.0, 1.0], dist: 0.0 },
        ];
        let open =
            |cluster, x0: f32, x1: f32| leaf(Contents::Empty, cluster, [x0, -32.0, 0.0], [x1, 32.0, 64.0]);
        let leaves = vec![
            leaf(Contents::Solid, -1, [-1e4; 3], [1e4; 3]),
            open(0, 0.0, 64.0),
            open(1, 64.0, 128.0),
            open(2, 136.0, 200.0),
        ];
        // Node 0: y <= 32 (else solid); node 1: y >= -32; node 2: z <= 64; node 3: z >= 0;
        // node 4: x >= 0; node 5: x < 200; node 6: split at 128: back → node 7 (x>=64 → leaf 2,
        // else leaf 1), front → node 8 (x >= 136 → leaf 3, else solid).
        let nodes = vec![
            Node { plane: 5, children: [-1, 1], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 6, children: [2, -1], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 7, children: [-1, 3], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 8, children: [4, -1], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 0, children: [5, -1], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 4, children: [-1, 6], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 2, children: [8, 7], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 1, children: [-3, -2], mins: [-1e4; 3], maxs: [1e4; 3] },
            Node { plane: 3, children: [-4, -1], mins: [-1e4; 3], maxs: [1e4; 3] },
        ];
        let models = vec![Model {
            head_node: 0,
            mins: [0.0; 3],
            maxs: [200.0, 32.0, 64.0],
            first_face: 0,
            num_faces: 0,
        }];
        Level { planes, nodes, leaves, models, num_clusters: 3, ..Level::default() }
    }

    #[test]
    fn leaf_at_finds_cells() {
        let level = corridor();
        let tree = BspTree::new(&level).unwrap();
        assert_eq!(tree.leaf_at(DVec3::new(10.0, 0.0, 10.0)), 1);
        assert_eq!(tree.leaf_at(DVec3::new(100.0, 0.0, 10.0)), 2);
        assert_eq!(tree.leaf_at(DVec3::new(130.0, 0.0, 10.0)), 0);
        assert_eq!(tree.leaf_at(DVec3::new(150.0, 0.0, 10.0)), 3);
        assert_eq!(tree.leaf_at(DVec3::new(150.0, 40.0, 10.0)), 0);
    }

    #[test]
    fn trace_stops_at_first_solid() {
        let level = corridor();
        let tree = BspTree::new(&level).unwrap();
        let (mut out, mut stack) = (Vec::new(), Vec::new());
        let hit = tree.trace(DVec3::new(10.0, 0.0, 10.0), DVec3::new(190.0, 0.0, 10.0), &mut out, &mut stack);
        let leaves: Vec<u32> = out.iter().map(|c| c.leaf).collect();
        assert_eq!(leaves, vec![1, 2]);
        let hit = hit.unwrap();
        assert!((hit.t - 118.0 / 180.0).abs() < 1e-9);
        assert_eq!(hit.normal, DVec3::new(-1.0, 0.0, 0.0));
        // Backwards from leaf 3 the wall is hit from the other side.
        out.clear();
        let hit = tree.trace(DVec3::new(190.0, 0.0, 10.0), DVec3::new(10.0, 0.0, 10.0), &mut out, &mut stack);
        assert_eq!(out.iter().map(|c| c.leaf).collect::<Vec<_>>(), vec![3]);
        assert_eq!(hit.unwrap().normal, DVec3::new(1.0, 0.0, 0.0));
        // Through solid, the wall is listed and the cell beyond it too.
        out.clear();
        let hit = tree.trace_through(
            DVec3::new(10.0, 0.0, 10.0),
            DVec3::new(190.0, 0.0, 10.0),
            &mut out,
            &mut stack,
        );
        assert_eq!(out.iter().map(|c| c.leaf).collect::<Vec<_>>(), vec![1, 2, 0, 3]);
        assert_eq!(hit.unwrap().leaf, 0);
    }

    #[test]
    fn rejects_cycles_and_bad_indices() {
        let mut level = corridor();
        level.nodes[7].children[0] = 0;
        assert!(BspTree::new(&level).is_err());
        let mut level = corridor();
        level.nodes[7].children[0] = -100;
        assert!(BspTree::new(&level).is_err());
        let mut level = corridor();
        level.nodes[3].plane = 99;
        assert!(BspTree::new(&level).is_err());
    }
}
