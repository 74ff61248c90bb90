//! Reading and validating BSP lumps.

use super::lumps::{invalid, lump_records, read_lump_table};
use super::{
    Bsp, BspError, BspFace, BspLeaf, BspModel, BspNode, BspPlane, BspVersion, Game, HEADER_BYTES, LumpEntry,
    MipTex, NUM_LUMPS, TexInfo, lump,
};
use crate::le::Rec;
use crate::tree_check::find_cycle;

fn face_bytes(version: BspVersion) -> usize {
    if version.narrow() { 20 } else { 28 }
}

/// The lump's bytes split into records of `size`, each with its byte offset in the file.
fn records<'a>(
    bytes: &'a [u8],
    lumps: &[LumpEntry; NUM_LUMPS],
    index: usize,
    size: usize,
) -> Result<impl Iterator<Item = (usize, Rec<'a>)>, BspError> {
    lump_records(bytes, lumps, &lump::NAMES, index, size)
}

/// Checks that `first..first + count` lies within `0..len`.
pub(super) fn check_range(
    offset: usize,
    what: &str,
    index: usize,
    first: u64,
    count: u64,
    len: usize,
    of: &str,
) -> Result<(), BspError> {
    if first + count > len as u64 {
        return Err(invalid(
            offset,
            format!("{what} {index}"),
            format!("{of} {first}..{} outside the {len} {of}", first + count),
        ));
    }
    Ok(())
}

/// Checks that `value` indexes `0..len`.
pub(super) fn check_index(
    offset: usize,
    what: &str,
    index: usize,
    value: u64,
    len: usize,
    of: &str,
) -> Result<(), BspError> {
    if value >= len as u64 {
        return Err(invalid(offset, format!("{what} {index}"), format!("{of} index {value} >= {len} {of}")));
    }
    Ok(())
}

pub(super) fn non_negative(
    offset: usize,
    what: &str,
    index: usize,
    field: &str,
    value: i32,
) -> Result<u32, BspError> {
    u32::try_from(value)
        .map_err(|_| invalid(offset, format!("{what} {index}"), format!("negative {field} {value}")))
}

pub(super) fn read_header(bytes: &[u8]) -> Result<(BspVersion, [LumpEntry; NUM_LUMPS]), BspError> {
    if let Some(game @ (Game::Quake2 | Game::Quake3)) = Game::sniff(bytes) {
        let version = bytes.get(4..8).map_or(0, |v| i32::from_le_bytes([v[0], v[1], v[2], v[3]]));
        return Err(BspError::OtherGame { game, version });
    }
    if bytes.len() < HEADER_BYTES {
        return Err(BspError::TooShort { len: bytes.len() });
    }
    let mut head = Rec::new(bytes);
    let magic: [u8; 4] = head.take();
    let version =
        BspVersion::ALL.into_iter().find(|v| v.magic() == magic).ok_or(BspError::Version { magic })?;
    Ok((version, read_lump_table(bytes, &mut head, &lump::NAMES)?))
}

fn read_textures(bytes: &[u8], entry: LumpEntry) -> Result<Vec<Option<MipTex>>, BspError> {
    let data = bytes.get(entry.offset..entry.end()).unwrap_or_default();
    if data.is_empty() {
        return Ok(Vec::new());
    }
    let mut head = Rec::new(data);
    let count = head.i32();
    let count =
        usize::try_from(count).ok().filter(|&n| data.len() >= 4 && (data.len() - 4) / 4 >= n).ok_or_else(
            || invalid(entry.offset, "texture directory", format!("count {count} does not fit the lump")),
        )?;
    let mut textures = Vec::with_capacity(count);
    for i in 0..count {
        let ofs = head.i32();
        if ofs == -1 {
            textures.push(None);
            continue;
        }
        let what = || format!("texture {i}");
        let header =
            usize::try_from(ofs).ok().and_then(|o| data.get(o..o.checked_add(40)?)).ok_or_else(|| {
                invalid(entry.offset + 4 + 4 * i, what(), format!("offset {ofs} outside the lump"))
            })?;
        let mut rec = Rec::new(header);
        let name_bytes: [u8; 16] = rec.take();
        let name_len = name_bytes.iter().position(|&b| b == 0).unwrap_or(16);
        let name = String::from_utf8_lossy(&name_bytes[..name_len]).into_owned();
        textures.push(Some(MipTex { name, width: rec.u32(), height: rec.u32() }));
    }
    Ok(textures)
}

pub(super) fn read(bytes: &[u8]) -> Result<Bsp, BspError> {
    let (version, lumps) = read_header(bytes)?;
    let wide = !version.narrow();

    let ent = &bytes[lumps[lump::ENTITIES].offset..lumps[lump::ENTITIES].end()];
    let ent = &ent[..ent.iter().position(|&b| b == 0).unwrap_or(ent.len())];
    let entities = String::from_utf8_lossy(ent).into_owned();

    let planes: Vec<BspPlane> = records(bytes, &lumps, lump::PLANES, 20)?
        .map(|(_, mut r)| BspPlane { normal: r.vec3(), dist: r.f32(), kind: r.i32() })
        .collect();
    let textures = read_textures(bytes, lumps[lump::TEXTURES])?;
    let vertices: Vec<[f32; 3]> =
        records(bytes, &lumps, lump::VERTICES, 12)?.map(|(_, mut r)| r.vec3()).collect();
    let visdata = bytes[lumps[lump::VISIBILITY].offset..lumps[lump::VISIBILITY].end()].to_vec();

    // Nodes: children are decoded once the leaf count is known.
    let node_size = version.node_bytes();
    let mut raw_children = Vec::new();
    let mut nodes = Vec::new();
    for (offset, mut r) in records(bytes, &lumps, lump::NODES, node_size)? {
        let plane = non_negative(offset, "node", nodes.len(), "plane", r.i32())?;
        let children =
            if wide { [i64::from(r.i32()), i64::from(r.i32())] } else { [r.u16().into(), r.u16().into()] };
        let (mins, maxs) = match version {
            BspVersion::Bsp2 => (r.vec3(), r.vec3()),
            _ => (r.vec3_i16(), r.vec3_i16()),
        };
        let (first_face, num_faces) =
            if wide { (r.u32(), r.u32()) } else { (r.u16().into(), r.u16().into()) };
        raw_children.push((offset, children));
        nodes.push(BspNode { plane, children: [0; 2], mins, maxs, first_face, num_faces });
    }

    let texinfo: Vec<TexInfo> = records(bytes, &lumps, lump::TEXINFO, 40)?
        .enumerate()
        .map(|(i, (offset, mut r))| {
            let vecs = [[r.f32(), r.f32(), r.f32(), r.f32()], [r.f32(), r.f32(), r.f32(), r.f32()]];
            let miptex = non_negative(offset, "texinfo", i, "miptex", r.i32())?;
            check_index(offset, "texinfo", i, miptex.into(), textures.len(), "textures")?;
            Ok(TexInfo { vecs, miptex, flags: r.i32() })
        })
        .collect::<Result<_, BspError>>()?;

    let face_size = face_bytes(version);
    let mut faces = Vec::new();
    for (offset, mut r) in records(bytes, &lumps, lump::FACES, face_size)? {
        let i = faces.len();
        let face = if wide {
            let plane = non_negative(offset, "face", i, "plane", r.i32())?;
            let back = r.i32() != 0;
            let first_edge = non_negative(offset, "face", i, "first edge", r.i32())?;
            let num_edges = non_negative(offset, "face", i, "edge count", r.i32())?;
            let texinfo = non_negative(offset, "face", i, "texinfo", r.i32())?;
            BspFace { plane, back, first_edge, num_edges, texinfo, styles: r.take(), light_offset: r.i32() }
        } else {
            let plane = r.u16().into();
            let back = r.i16() != 0;
            let first_edge = non_negative(offset, "face", i, "first edge", r.i32())?;
            let num_edges = r.u16().into();
            let texinfo = r.u16().into();
            BspFace { plane, back, first_edge, num_edges, texinfo, styles: r.take(), light_offset: r.i32() }
        };
        faces.push(face);
    }

    let clip_size = if wide { 12 } else { 8 };
    let num_clipnodes = records(bytes, &lumps, lump::CLIPNODES, clip_size)?.count();

    let leaf_size = version.leaf_bytes();
    let leaves: Vec<BspLeaf> = records(bytes, &lumps, lump::LEAVES, leaf_size)?
        .map(|(_, mut r)| {
            let contents = r.i32();
            let visofs = r.i32();
            let (mins, maxs) = match version {
                BspVersion::Bsp2 => (r.vec3(), r.vec3()),
                _ => (r.vec3_i16(), r.vec3_i16()),
            };
            let (first_marksurface, num_marksurfaces) =
                if wide { (r.u32(), r.u32()) } else { (r.u16().into(), r.u16().into()) };
            BspLeaf { contents, visofs, mins, maxs, first_marksurface, num_marksurfaces, ambient: r.take() }
        })
        .collect();

    let marksurfaces: Vec<u32> = if wide {
        records(bytes, &lumps, lump::MARKSURFACES, 4)?.map(|(_, mut r)| r.u32()).collect()
    } else {
        records(bytes, &lumps, lump::MARKSURFACES, 2)?.map(|(_, mut r)| r.u16().into()).collect()
    };
    let edges: Vec<[u32; 2]> = if wide {
        records(bytes, &lumps, lump::EDGES, 8)?.map(|(_, mut r)| [r.u32(), r.u32()]).collect()
    } else {
        records(bytes, &lumps, lump::EDGES, 4)?.map(|(_, mut r)| [r.u16().into(), r.u16().into()]).collect()
    };
    let surfedges: Vec<i32> = records(bytes, &lumps, lump::SURFEDGES, 4)?.map(|(_, mut r)| r.i32()).collect();

    let mut models = Vec::new();
    for (offset, mut r) in records(bytes, &lumps, lump::MODELS, 64)? {
        let i = models.len();
        let (mins, maxs, origin) = (r.vec3(), r.vec3(), r.vec3());
        let head_nodes = [r.i32(), r.i32(), r.i32(), r.i32()];
        let visleafs = non_negative(offset, "model", i, "visleafs", r.i32())?;
        let first_face = non_negative(offset, "model", i, "first face", r.i32())?;
        let num_faces = non_negative(offset, "model", i, "face count", r.i32())?;
        models.push(BspModel { mins, maxs, origin, head_nodes, visleafs, first_face, num_faces });
    }

    let mut bsp = Bsp {
        version,
        lumps,
        entities,
        planes,
        textures,
        vertices,
        visdata,
        nodes,
        texinfo,
        faces,
        num_clipnodes,
        leaves,
        marksurfaces,
        edges,
        surfedges,
        models,
    };
    resolve_children(&mut bsp, &raw_children)?;
    validate(&bsp)?;
    Ok(bsp)
}

/// Decodes stored children into Quake's signed encoding and checks them.
fn resolve_children(bsp: &mut Bsp, raw: &[(usize, [i64; 2])]) -> Result<(), BspError> {
    let (num_nodes, num_leaves) = (bsp.nodes.len(), bsp.leaves.len());
    let narrow = bsp.version.narrow();
    for (i, (node, &(offset, stored))) in bsp.nodes.iter_mut().zip(raw).enumerate() {
        for (child, &value) in node.children.iter_mut().zip(&stored) {
            let decoded = if narrow && value >= num_nodes as i64 { -(65535 - value) - 1 } else { value };
            let ok =
                if decoded >= 0 { decoded < num_nodes as i64 } else { -(decoded + 1) < num_leaves as i64 };
            if !ok {
                return Err(invalid(offset, format!("node {i}"), format!("bad child {value}")));
            }
            // In range of i32 because it indexes an in-memory vector of records.
            *child = decoded as i32;
        }
    }
    let children: Vec<[i32; 2]> = bsp.nodes.iter().map(|n| n.children).collect();
    if let Some(i) = find_cycle(&children) {
        let offset = raw.get(i).map_or(0, |r| r.0);
        return Err(invalid(offset, format!("node {i}"), "lies on a cycle of nodes"));
    }
    Ok(())
}

/// Byte offset of record `index` of lump `which`.
fn rec_offset(bsp: &Bsp, which: usize, size: usize, index: usize) -> usize {
    bsp.lumps[which].offset + index * size
}

fn validate(bsp: &Bsp) -> Result<(), BspError> {
    let v = bsp.version;
    for (i, p) in bsp.planes.iter().enumerate() {
        if !p.normal.iter().chain([&p.dist]).all(|c| c.is_finite()) {
            return Err(invalid(rec_offset(bsp, lump::PLANES, 20, i), format!("plane {i}"), "not finite"));
        }
    }
    for (i, v) in bsp.vertices.iter().enumerate() {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(invalid(rec_offset(bsp, lump::VERTICES, 12, i), format!("vertex {i}"), "not finite"));
        }
    }
    let node_size = v.node_bytes();
    for (i, n) in bsp.nodes.iter().enumerate() {
        let at = rec_offset(bsp, lump::NODES, node_size, i);
        check_index(at, "node", i, n.plane.into(), bsp.planes.len(), "planes")?;
        check_range(at, "node", i, n.first_face.into(), n.num_faces.into(), bsp.faces.len(), "faces")?;
    }
    let face_size = face_bytes(v);
    for (i, f) in bsp.faces.iter().enumerate() {
        let at = rec_offset(bsp, lump::FACES, face_size, i);
        check_index(at, "face", i, f.plane.into(), bsp.planes.len(), "planes")?;
        check_index(at, "face", i, f.texinfo.into(), bsp.texinfo.len(), "texinfo")?;
        if f.num_edges < 3 {
            return Err(invalid(at, format!("face {i}"), format!("{} edges", f.num_edges)));
        }
        check_range(
            at,
            "face",
            i,
            f.first_edge.into(),
            f.num_edges.into(),
            bsp.surfedges.len(),
            "surfedges",
        )?;
    }
    for (i, &e) in bsp.surfedges.iter().enumerate() {
        let at = rec_offset(bsp, lump::SURFEDGES, 4, i);
        check_index(at, "surfedge", i, e.unsigned_abs().into(), bsp.edges.len(), "edges")?;
    }
    let edge_size = if v.narrow() { 4 } else { 8 };
    for (i, e) in bsp.edges.iter().enumerate() {
        let at = rec_offset(bsp, lump::EDGES, edge_size, i);
        for &vert in e {
            check_index(at, "edge", i, vert.into(), bsp.vertices.len(), "vertices")?;
        }
    }
    let mark_size = if v.narrow() { 2 } else { 4 };
    for (i, &m) in bsp.marksurfaces.iter().enumerate() {
        check_index(
            rec_offset(bsp, lump::MARKSURFACES, mark_size, i),
            "marksurface",
            i,
            m.into(),
            bsp.faces.len(),
            "faces",
        )?;
    }
    for (i, m) in bsp.models.iter().enumerate() {
        let at = rec_offset(bsp, lump::MODELS, 64, i);
        check_range(at, "model", i, m.first_face.into(), m.num_faces.into(), bsp.faces.len(), "faces")?;
        let head = m.head_nodes[0];
        let ok = if head >= 0 {
            (head as usize) < bsp.nodes.len()
        } else {
            (-(i64::from(head) + 1) as u64) < bsp.leaves.len() as u64
        };
        if !ok {
            return Err(invalid(at, format!("model {i}"), format!("bad head node {head}")));
        }
        // Without clipnodes (qbsp -noclip) the file has no clip hulls and their roots (0) name
        // nothing: nothing reads them. With clipnodes, a root must name one.
        for &clip in &m.head_nodes[1..] {
            if bsp.num_clipnodes > 0 && clip >= 0 && clip as usize >= bsp.num_clipnodes {
                return Err(invalid(
                    at,
                    format!("model {i}"),
                    format!("clip hull root {clip} >= {} clipnodes", bsp.num_clipnodes),
                ));
            }
        }
    }
    let Some(world) = bsp.models.first() else {
        return Err(invalid(bsp.lumps[lump::MODELS].offset, "models", "no world model"));
    };
    let visleafs = world.visleafs as usize;
    if visleafs >= bsp.leaves.len().max(1) {
        return Err(invalid(
            bsp.lumps[lump::MODELS].offset,
            "model 0",
            format!("visleafs {visleafs} but only {} leaves", bsp.leaves.len()),
        ));
    }
    let leaf_size = v.leaf_bytes();
    let mut row = vec![0; bsp.row_bytes()];
    let mut checked_ofs = std::collections::HashSet::new();
    for (i, l) in bsp.leaves.iter().enumerate() {
        let at = rec_offset(bsp, lump::LEAVES, leaf_size, i);
        check_range(
            at,
            "leaf",
            i,
            l.first_marksurface.into(),
            l.num_marksurfaces.into(),
            bsp.marksurfaces.len(),
            "marksurfaces",
        )?;
        // Engines only read the rows of vis leaves, and none when the visdata is empty (qbsp
        // leaves stale offsets there), so only those are checked.
        if !(1..=visleafs).contains(&i) || bsp.visdata.is_empty() || l.visofs == -1 {
            continue;
        }
        if l.visofs < -1 || l.visofs as usize >= bsp.visdata.len() {
            return Err(invalid(
                at,
                format!("leaf {i}"),
                format!("visofs {} outside the {}-byte visdata", l.visofs, bsp.visdata.len()),
            ));
        }
        // Each distinct row is decoded once: leaves of a cluster share their row.
        if checked_ofs.insert(l.visofs) {
            bsp.decode_leaf_pvs_into(i, &mut row)?;
        }
    }
    Ok(())
}
