//! Index validation of a whole level: after [`validate`] succeeds, every index stored in the level
//! is in range, the node graph has no cycle, and every PVS row decodes.
//!
//! These are the rules every reader of a [`Level`] shares, and this is the only place that states
//! them: [`super::read`] runs [`validate`] on every file, `bsp::to_level` produces levels that
//! pass it, and the runtime's `World::new` runs it on every level before adding only its own
//! rules (unit normals, a strict world tree of bounded depth, ...). A rule every consumer needs
//! belongs here, not in a consumer.

use super::{LumpKind, SlvlError};
use crate::level::{Contents, Level};
use crate::rle;
use crate::tree_check::find_cycle;
use std::collections::HashSet;

struct Check {
    kind: LumpKind,
    index: usize,
}

impl Check {
    fn at(kind: LumpKind, index: usize) -> Self {
        Self { kind, index }
    }

    fn fail(&self, detail: impl Into<String>) -> SlvlError {
        let offset = (self.index * self.kind.record_bytes().max(1)) as u64;
        SlvlError::Invalid { lump: self.kind.name(), index: self.index, offset, detail: detail.into() }
    }

    fn index(&self, field: &str, value: u32, len: usize, of: &str) -> Result<(), SlvlError> {
        if value as usize >= len {
            return Err(self.fail(format!("{field} {value} >= {len} {of}")));
        }
        Ok(())
    }

    fn range(&self, first: u32, count: u32, len: usize, of: &str) -> Result<(), SlvlError> {
        if u64::from(first) + u64::from(count) > len as u64 {
            return Err(self.fail(format!(
                "{of} {first}..{} outside the {len} {of}",
                u64::from(first) + u64::from(count)
            )));
        }
        Ok(())
    }

    fn child(&self, child: i32, nodes: usize, leaves: usize) -> Result<(), SlvlError> {
        let ok = match usize::try_from(child) {
            Ok(node) => node < nodes,
            Err(_) => (-(i64::from(child) + 1) as u64) < leaves as u64,
        };
        if !ok {
            return Err(self
                .fail(format!("child {child} is neither one of {nodes} nodes nor one of {leaves} leaves")));
        }
        Ok(())
    }

    fn finite<'a>(&self, what: &str, values: impl IntoIterator<Item = &'a f32>) -> Result<(), SlvlError> {
        if values.into_iter().any(|v| !v.is_finite()) {
            return Err(self.fail(format!("{what} is not finite")));
        }
        Ok(())
    }
}

/// Checks every index and invariant a reader of the level relies on (see the module docs of
/// [`crate::level`]): every coordinate, bound and plane finite; node planes and children in range and acyclic;
/// leaf face ranges in `leaf_faces`; solid leaves in cluster -1 and other clusters below
/// `num_clusters`; `leaf_faces` entries below the face count; faces with at least 3 corners in
/// range and a valid plane and texture; portals between existing leaves with a valid plane and at
/// least 3 corners; a world model (model 0) when the level has a tree (a level of faces alone, such
/// as GVS results for a mesh, has none), and every model's head node and face range;
/// `num_clusters` at most the leaf count;
/// `pvs_offsets` empty or one per cluster, each pointing at a row that decodes; GVS cell face
/// ranges and GVS face indices; `face_draw` and `texture_sizes` empty or one per face (texture),
/// texture axes finite.
pub fn validate(level: &Level) -> Result<(), SlvlError> {
    let (planes, nodes, leaves) = (level.planes.len(), level.nodes.len(), level.leaves.len());
    let faces = level.faces.len();
    for (i, p) in level.planes.iter().enumerate() {
        Check::at(LumpKind::Planes, i).finite("plane", p.normal.iter().chain([&p.dist]))?;
    }
    for (i, v) in level.vertices.iter().enumerate() {
        Check::at(LumpKind::Vertices, i).finite("vertex", v)?;
    }
    for (i, n) in level.nodes.iter().enumerate() {
        let c = Check::at(LumpKind::Nodes, i);
        c.finite("bounds", n.mins.iter().chain(&n.maxs))?;
        c.index("plane", n.plane, planes, "planes")?;
        for &child in &n.children {
            c.child(child, nodes, leaves)?;
        }
    }
    let children: Vec<[i32; 2]> = level.nodes.iter().map(|n| n.children).collect();
    if let Some(i) = find_cycle(&children) {
        return Err(Check::at(LumpKind::Nodes, i).fail("node lies on a cycle"));
    }
    if level.num_clusters as usize > leaves {
        return Err(Check::at(LumpKind::Clusters, 0)
            .fail(format!("{} clusters for {leaves} leaves", level.num_clusters)));
    }
    for (i, l) in level.leaves.iter().enumerate() {
        let c = Check::at(LumpKind::Leaves, i);
        c.finite("bounds", l.mins.iter().chain(&l.maxs))?;
        c.range(l.first_face, l.num_faces, level.leaf_faces.len(), "leaf_faces")?;
        let cluster_ok = if l.contents == Contents::Solid {
            l.cluster == -1
        } else {
            l.cluster == -1 || u32::try_from(l.cluster).is_ok_and(|k| k < level.num_clusters)
        };
        if !cluster_ok {
            return Err(
                c.fail(format!("{:?} leaf in cluster {} of {}", l.contents, l.cluster, level.num_clusters))
            );
        }
    }
    for (i, &f) in level.leaf_faces.iter().enumerate() {
        Check::at(LumpKind::LeafFaces, i).index("face", f, faces, "faces")?;
    }
    for (i, f) in level.faces.iter().enumerate() {
        let c = Check::at(LumpKind::Faces, i);
        c.index("plane", f.plane, planes, "planes")?;
        c.index("texture", f.texture, level.textures.len(), "textures")?;
        if f.num_vertices < 3 {
            return Err(c.fail(format!("{} corners", f.num_vertices)));
        }
        c.range(f.first_vertex, f.num_vertices, level.vertices.len(), "vertices")?;
    }
    for (i, p) in level.portals.iter().enumerate() {
        let c = Check::at(LumpKind::Portals, i);
        for &leaf in &p.leaves {
            c.index("leaf", leaf, leaves, "leaves")?;
        }
        c.index("plane", p.plane, planes, "planes")?;
        if p.num_vertices < 3 {
            return Err(c.fail(format!("{} corners", p.num_vertices)));
        }
        c.range(p.first_vertex, p.num_vertices, level.vertices.len(), "vertices")?;
    }
    for (i, m) in level.models.iter().enumerate() {
        let c = Check::at(LumpKind::Models, i);
        c.finite("bounds", m.mins.iter().chain(&m.maxs))?;
        c.child(m.head_node, nodes, leaves)?;
        c.range(m.first_face, m.num_faces, faces, "faces")?;
    }
    if level.models.is_empty() && !(level.nodes.is_empty() && level.leaves.is_empty()) {
        let (n, l) = (level.nodes.len(), level.leaves.len());
        let detail = format!("no world model (model 0) to root the tree of {n} nodes and {l} leaves");
        return Err(Check::at(LumpKind::Models, 0).fail(detail));
    }
    validate_pvs(level)?;
    for (i, cell) in level.gvs_cells.iter().enumerate() {
        let c = Check::at(LumpKind::GvsCells, i);
        c.finite("bounds", cell.mins.iter().chain(&cell.maxs))?;
        c.range(cell.first_face, cell.num_faces, level.gvs_faces.len(), "gvs_faces")?;
    }
    for (i, &f) in level.gvs_faces.iter().enumerate() {
        Check::at(LumpKind::GvsFaces, i).index("face", f, faces, "faces")?;
    }
    validate_draw(level)
}

/// `face_draw` and `texture_sizes`: each empty or one record per face (texture); axes finite.
fn validate_draw(level: &Level) -> Result<(), SlvlError> {
    let (faces, textures) = (level.faces.len(), level.textures.len());
    if !level.face_draw.is_empty() && level.face_draw.len() != faces {
        return Err(Check::at(LumpKind::FaceDraw, 0)
            .fail(format!("{} records for {faces} faces", level.face_draw.len())));
    }
    for (i, d) in level.face_draw.iter().enumerate() {
        Check::at(LumpKind::FaceDraw, i).finite("texture axis", d.s.iter().chain(&d.t))?;
    }
    if !level.texture_sizes.is_empty() && level.texture_sizes.len() != textures {
        return Err(Check::at(LumpKind::TextureSizes, 0)
            .fail(format!("{} records for {textures} textures", level.texture_sizes.len())));
    }
    Ok(())
}

fn validate_pvs(level: &Level) -> Result<(), SlvlError> {
    if level.pvs_offsets.is_empty() {
        return Ok(());
    }
    if level.pvs_offsets.len() != level.num_clusters as usize {
        return Err(Check::at(LumpKind::PvsOffsets, 0).fail(format!(
            "{} rows for {} clusters",
            level.pvs_offsets.len(),
            level.num_clusters
        )));
    }
    let mut row = vec![0; level.row_bytes()];
    let mut decoded = HashSet::new();
    for (i, &ofs) in level.pvs_offsets.iter().enumerate() {
        if !decoded.insert(ofs) {
            continue;
        }
        let c = Check::at(LumpKind::PvsOffsets, i);
        let data = level.pvs_data.get(ofs as usize..).filter(|d| !d.is_empty());
        let Some(data) = data else {
            return Err(
                c.fail(format!("row offset {ofs} outside the {}-byte pvs_data", level.pvs_data.len()))
            );
        };
        rle::decode_row(data, row.len(), &mut row).map_err(|e| c.fail(format!("row at {ofs}: {e}")))?;
    }
    Ok(())
}
