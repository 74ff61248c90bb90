//! Level fields to lump bytes (fixed-layout little-endian records, see `docs/slvl.md`).

use super::{DIR_ENTRY_BYTES, DirEntry, LumpKind};
use crate::level::Level;

/// Little-endian record writer.
struct Put(Vec<u8>);

impl Put {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn i32(&mut self, v: i32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn vec3(&mut self, v: [f32; 3]) {
        v.into_iter().for_each(|c| self.f32(c));
    }
}

pub(super) fn dir_entry(e: &DirEntry) -> [u8; DIR_ENTRY_BYTES] {
    let mut p = Put(Vec::with_capacity(DIR_ENTRY_BYTES));
    p.u32(e.kind);
    p.u32(e.codec);
    p.u64(e.offset);
    p.u64(e.length);
    p.u64(e.uncompressed_length);
    p.u32(e.checksum);
    p.u32(0);
    let mut out = [0; DIR_ENTRY_BYTES];
    out.copy_from_slice(&p.0);
    out
}

pub(super) fn lump_bytes(level: &Level, kind: LumpKind) -> Vec<u8> {
    let mut p = Put(Vec::new());
    match kind {
        LumpKind::Entities => p.0.extend_from_slice(level.entities.as_bytes()),
        LumpKind::Textures => {
            for name in &level.textures {
                p.u32(name.len() as u32);
                p.0.extend_from_slice(name.as_bytes());
            }
        }
        LumpKind::Planes => {
            for plane in &level.planes {
                p.vec3(plane.normal);
                p.f32(plane.dist);
            }
        }
        LumpKind::Nodes => {
            for n in &level.nodes {
                p.u32(n.plane);
                p.i32(n.children[0]);
                p.i32(n.children[1]);
                p.vec3(n.mins);
                p.vec3(n.maxs);
            }
        }
        LumpKind::Leaves => {
            for l in &level.leaves {
                p.i32(l.contents.code());
                p.i32(l.cluster);
                p.vec3(l.mins);
                p.vec3(l.maxs);
                p.u32(l.first_face);
                p.u32(l.num_faces);
            }
        }
        LumpKind::LeafFaces => level.leaf_faces.iter().for_each(|&f| p.u32(f)),
        LumpKind::Faces => {
            for f in &level.faces {
                p.u32(f.plane);
                p.u32(f.first_vertex);
                p.u32(f.num_vertices);
                p.u32(f.texture);
            }
        }
        LumpKind::Vertices => level.vertices.iter().for_each(|&v| p.vec3(v)),
        LumpKind::Portals => {
            for portal in &level.portals {
                p.u32(portal.leaves[0]);
                p.u32(portal.leaves[1]);
                p.u32(portal.plane);
                p.u32(portal.first_vertex);
                p.u32(portal.num_vertices);
            }
        }
        LumpKind::Models => {
            for m in &level.models {
                p.i32(m.head_node);
                p.vec3(m.mins);
                p.vec3(m.maxs);
                p.u32(m.first_face);
                p.u32(m.num_faces);
            }
        }
        LumpKind::Clusters => p.u32(level.num_clusters),
        LumpKind::PvsOffsets => level.pvs_offsets.iter().for_each(|&o| p.u32(o)),
        LumpKind::PvsData => p.0.extend_from_slice(&level.pvs_data),
        LumpKind::GvsCells => {
            for c in &level.gvs_cells {
                p.vec3(c.mins);
                p.vec3(c.maxs);
                p.u32(c.first_face);
                p.u32(c.num_faces);
            }
        }
        LumpKind::GvsFaces => level.gvs_faces.iter().for_each(|&f| p.u32(f)),
        LumpKind::FaceDraw => {
            for d in &level.face_draw {
                d.s.into_iter().chain(d.t).for_each(|v| p.f32(v));
                p.u32(d.flags);
                p.0.extend_from_slice(&d.styles);
                p.i32(d.light_offset);
            }
        }
        LumpKind::TextureSizes => level.texture_sizes.iter().flatten().for_each(|&v| p.u32(v)),
        LumpKind::PortalFile => level.portal_file.into_iter().for_each(|h| p.u64(h)),
    }
    p.0
}
