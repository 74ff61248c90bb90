//! `func_viscluster`: a brush entity whose volume is one cluster for vis, so the flow treats an
//! open area as a single cell (far less work on big open maps, at the price of a looser PVS).
//!
//! # Conventions
//! - Its brushes are not geometry: they build no tree, seal nothing, block nothing and are not in
//!   the level (like a trigger's); a map with them has the same solid world, the same outside
//!   fill and the same leak result as without them. The entity itself is not written to the
//!   level's entity text (the compiler consumes it, as `func_detail`).
//! - A brush is the intersection of the back half spaces of its sides' planes (the `.map`'s
//!   planes face out of the brush), taken as written: no side is dropped. Its planes must close
//!   a volume, as any brush's: one whose planes do not is refused at its line.
//! - **Inside**: a non-solid world leaf (after the outside fill) is inside an entity when the
//!   centre of the leaf's bounding box lies on or behind every plane of one of the entity's
//!   brushes, within [`ON_EPSILON`]. The box centre is a single point for any leaf, slanted or
//!   not (for a slanted leaf it may lie just outside the leaf itself, which only matters near the
//!   brush's faces); a leaf in solid is never inside.
//! - A leaf inside several entities goes to the first of them in map order.
//! - Each entity becomes one cluster: the leaves inside it, and every leaf sharing a cluster with
//!   one of them (a `func_detail` subtree is one cluster and stays whole, so it joins the entity
//!   too). Clusters are then numbered by first vis leaf as ever, and portals whose two sides fall
//!   in one cluster leave the `.prt`.
//!
//! # Why the PVS stays conservative
//! This is the merge `--coarsen` makes (see `vis::coarsen`), chosen by the mapper instead of by a
//! grid: a sight line crosses the portals that remain, consecutive ones sharing a merged cluster,
//! and every constraint vis puts on that shorter chain it put on the longer one before; so a
//! merged cluster sees whatever a line from any of its leaves reaches, and is seen along every
//! line that reaches any of them (pairs of the unmerged PVS that no line joins may go, see
//! `vis::coarsen`).

use glam::DVec3;
use sightline_formats::Contents;
use sightline_formats::geom::{ON_EPSILON, Plane};

use crate::bsp::{Tree, TreeNode};
use crate::contents::VISCLUSTER_CLASSNAME;

/// One `func_viscluster` entity as loaded.
#[derive(Debug, Clone)]
pub(crate) struct VisCluster {
    /// 1-based line of the entity in the map.
    pub line: u32,
    /// Each brush's side planes, facing out.
    pub brushes: Vec<Vec<Plane>>,
}

impl VisCluster {
    /// `p` lies inside one of the brushes (on or behind every plane of it).
    fn contains(&self, p: DVec3) -> bool {
        self.brushes.iter().any(|b| b.iter().all(|pl| pl.distance(p) <= ON_EPSILON))
    }
}

/// What one `func_viscluster` merged, for the report.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct VisClusterStat {
    /// 1-based line of the entity in the map.
    pub line: u32,
    /// Vis leaves in its cluster.
    pub leaves: usize,
}

/// For every index of `tree`, the entity (an index into `clusters`) whose volume holds it: only
/// leaves whose `contents` are not solid, by the rule in the module docs. Empty when there are
/// no entities (nothing changes).
pub(crate) fn leaf_groups(tree: &Tree, contents: &[Contents], clusters: &[VisCluster]) -> Vec<Option<u32>> {
    if clusters.is_empty() {
        return Vec::new();
    }
    tree.nodes
        .iter()
        .enumerate()
        .map(|(i, n)| match n {
            TreeNode::Leaf { bounds, .. } if contents.get(i).is_some_and(|c| *c != Contents::Solid) => {
                let centre = (bounds.mins + bounds.maxs) * 0.5;
                clusters.iter().position(|c| c.contains(centre)).map(|g| g as u32)
            }
            _ => None,
        })
        .collect()
}

/// Give every tree index whose cluster key holds a leaf of an entity (`groups`, from
/// [`leaf_groups`]) the key `keys.len() + entity` instead; the lowest entity wins when one key
/// holds leaves of several. `keys` are per tree index, as `emit` numbers clusters.
pub(crate) fn merge_keys(keys: &mut [u32], groups: &[Option<u32>]) {
    if groups.is_empty() {
        return;
    }
    let base = keys.len() as u32;
    let mut target: Vec<Option<u32>> = vec![None; keys.len()];
    for (t, g) in groups.iter().enumerate() {
        if let (Some(g), Some(&k)) = (g, keys.get(t))
            && let Some(slot) = target.get_mut(k as usize)
        {
            *slot = Some(slot.map_or(*g, |o| o.min(*g)));
        }
    }
    for k in keys.iter_mut() {
        if let Some(Some(g)) = target.get(*k as usize) {
            *k = base + g;
        }
    }
}

/// The merge `func_viscluster` entities ask of a compiled `.bsp` vised from its portal file
/// (see [`box_merge`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct BspMerge {
    /// Per cluster of the portal file, its merged cluster (numbered by lowest input cluster).
    pub new_id: Vec<u32>,
    /// Merged clusters.
    pub groups: u32,
    /// Per entity with a brush model, in entity order: the portal-file leaves it merged (vis
    /// leaves of a Quake 1 or Half-Life file, clusters of a Quake 2 or 3 one).
    pub leaves: Vec<usize>,
}

/// The merge for a Quake 1 or Half-Life `bsp` vised from `prt` ([`box_merge`]): vis leaf `j` of
/// `prt` is BSP leaf `j + 1`.
pub(crate) fn bsp_merge(
    bsp: &sightline_formats::bsp::Bsp,
    prt: &sightline_formats::prt::PortalFile,
) -> Option<BspMerge> {
    let boxes = |m: u32| bsp.models.get(m as usize).map(|m| (m.mins, m.maxs));
    let leaves =
        (0..prt.leaf_clusters.len()).filter_map(|j| bsp.leaves.get(j + 1).map(|l| (j, (l.mins, l.maxs))));
    box_merge(&bsp.entities, boxes, prt, leaves)
}

/// The merge for a Quake 2 or Quake 3 file read as `level`, whose portal file `prt` is over
/// clusters (portal-file leaf `c` is cluster `c`): a cluster merges when the centre of one of
/// its leaves lies in an entity's box ([`box_merge`]). `model_box` gives a brush model's stored
/// bounds (a Quake 3 level keeps only the world model, so its caller reads them from the file).
pub(crate) fn level_merge(
    level: &sightline_formats::level::Level,
    model_box: impl Fn(u32) -> Option<([f32; 3], [f32; 3])>,
    prt: &sightline_formats::prt::PortalFile,
) -> Option<BspMerge> {
    let leaves =
        level.leaves.iter().filter_map(|l| usize::try_from(l.cluster).ok().map(|c| (c, (l.mins, l.maxs))));
    box_merge(&level.entities, model_box, prt, leaves)
}

/// The merge for the `func_viscluster` entities of a compiled file's entity text, `None` when it
/// has none with a brush model (`"model" "*N"`, `N ≥ 1`, a model `model_box` knows) or the text
/// does not parse. A compiled file keeps no brush planes, so **inside** here is: the centre of
/// a leaf's stored bounds lies within the model's stored bounds (its box, which holds its
/// brushes: at worst a few more leaves merge, which stays conservative). `leaves` gives, per
/// leaf of the file, the portal-file leaf it belongs to and its bounds; a leaf whose bounds are
/// not finite, or whose portal-file leaf `prt` lacks, stays as it is. A cluster holding leaves of
/// several entities joins the first in entity order; every other cluster stays alone.
fn box_merge(
    entities: &str,
    model_box: impl Fn(u32) -> Option<([f32; 3], [f32; 3])>,
    prt: &sightline_formats::prt::PortalFile,
    leaves: impl Iterator<Item = (usize, ([f32; 3], [f32; 3]))>,
) -> Option<BspMerge> {
    let entities = sightline_formats::entities::parse(entities).ok()?;
    let v = |a: [f32; 3]| DVec3::from(a.map(f64::from));
    let boxes: Vec<(DVec3, DVec3)> = entities
        .iter()
        .filter(|e| e.classname() == VISCLUSTER_CLASSNAME)
        .filter_map(|e| e.model().filter(|&m| m >= 1))
        .filter_map(&model_box)
        .map(|(lo, hi)| (v(lo), v(hi)))
        .collect();
    if boxes.is_empty() {
        return None;
    }
    let nc = prt.num_clusters as usize;
    // Per portal-file leaf, the entity holding one of its file leaves (the lowest).
    let mut leaf_group: Vec<Option<usize>> = vec![None; prt.leaf_clusters.len()];
    for (j, (mins, maxs)) in leaves {
        let centre = (v(mins) + v(maxs)) * 0.5;
        if !centre.is_finite() {
            continue;
        }
        let g = boxes.iter().position(|(lo, hi)| centre.cmpge(*lo).all() && centre.cmple(*hi).all());
        if let (Some(g), Some(slot)) = (g, leaf_group.get_mut(j)) {
            *slot = Some(slot.map_or(g, |o| o.min(g)));
        }
    }
    let mut group: Vec<Option<usize>> = vec![None; nc];
    for (&c, g) in prt.leaf_clusters.iter().zip(&leaf_group) {
        if let (Some(g), Some(slot)) = (g, group.get_mut(c as usize)) {
            *slot = Some(slot.map_or(*g, |o| o.min(*g)));
        }
    }
    let mut first: Vec<Option<u32>> = vec![None; boxes.len()];
    let mut new_id = Vec::with_capacity(nc);
    let mut groups = 0u32;
    for g in &group {
        let id = match g.map(|g| &mut first[g]) {
            Some(Some(id)) => *id,
            slot => {
                let id = groups;
                groups += 1;
                if let Some(s) = slot {
                    *s = Some(id);
                }
                id
            }
        };
        new_id.push(id);
    }
    let mut merged = vec![0usize; boxes.len()];
    for &c in &prt.leaf_clusters {
        if let Some(Some(g)) = group.get(c as usize) {
            merged[*g] += 1;
        }
    }
    Some(BspMerge { new_id, groups, leaves: merged })
}
