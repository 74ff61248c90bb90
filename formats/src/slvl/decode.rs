//! Lump bytes to level fields. Only shapes are checked here (record sizes, UTF-8, contents
//! codes); indices are checked by [`super::validate`] once every lump is loaded.

use super::{LumpKind, SlvlError};
use crate::le::Rec;
use crate::level::{Contents, Face, FaceDraw, GvsCell, Leaf, Level, LevelPlane, Model, Node, Portal};

fn invalid(kind: LumpKind, index: usize, offset: usize, detail: impl Into<String>) -> SlvlError {
    SlvlError::Invalid { lump: kind.name(), index, offset: offset as u64, detail: detail.into() }
}

/// Splits `data` into records of `kind`'s size; `data` is at most the lump size, so collecting
/// the records allocates no more than the file justifies.
fn records(kind: LumpKind, data: &[u8]) -> Result<impl Iterator<Item = (usize, Rec<'_>)>, SlvlError> {
    let size = kind.record_bytes();
    if !data.len().is_multiple_of(size) {
        return Err(invalid(
            kind,
            data.len() / size,
            data.len(),
            format!("lump length {} is not a multiple of the {size}-byte record", data.len()),
        ));
    }
    Ok(data.chunks_exact(size).map(Rec::new).enumerate())
}

fn text(kind: LumpKind, index: usize, offset: usize, bytes: &[u8]) -> Result<String, SlvlError> {
    String::from_utf8(bytes.to_vec())
        .map_err(|e| invalid(kind, index, offset + e.utf8_error().valid_up_to(), "not UTF-8"))
}

pub(super) fn lump_into(level: &mut Level, kind: LumpKind, data: &[u8]) -> Result<(), SlvlError> {
    match kind {
        LumpKind::Entities => level.entities = text(kind, 0, 0, data)?,
        LumpKind::Textures => {
            let mut pos = 0;
            while pos < data.len() {
                let index = level.textures.len();
                let len = data.get(pos..pos + 4).map(|b| {
                    let mut r = Rec::new(b);
                    r.u32() as usize
                });
                let name = len
                    .and_then(|len| data.get(pos + 4..(pos + 4).checked_add(len)?))
                    .ok_or_else(|| invalid(kind, index, pos, "name runs past the end of the lump"))?;
                level.textures.push(text(kind, index, pos + 4, name)?);
                pos += 4 + name.len();
            }
        }
        LumpKind::Planes => {
            level.planes = records(kind, data)?
                .map(|(_, mut r)| LevelPlane { normal: r.vec3(), dist: r.f32() })
                .collect();
        }
        LumpKind::Nodes => {
            level.nodes = records(kind, data)?
                .map(|(_, mut r)| Node {
                    plane: r.u32(),
                    children: [r.i32(), r.i32()],
                    mins: r.vec3(),
                    maxs: r.vec3(),
                })
                .collect();
        }
        LumpKind::Leaves => {
            level.leaves = records(kind, data)?
                .map(|(i, mut r)| {
                    let code = r.i32();
                    let contents = Contents::from_code(code).ok_or_else(|| {
                        invalid(kind, i, i * kind.record_bytes(), format!("unknown contents {code}"))
                    })?;
                    Ok(Leaf {
                        contents,
                        cluster: r.i32(),
                        mins: r.vec3(),
                        maxs: r.vec3(),
                        first_face: r.u32(),
                        num_faces: r.u32(),
                    })
                })
                .collect::<Result<_, SlvlError>>()?;
        }
        LumpKind::LeafFaces => level.leaf_faces = records(kind, data)?.map(|(_, mut r)| r.u32()).collect(),
        LumpKind::Faces => {
            level.faces = records(kind, data)?
                .map(|(_, mut r)| Face {
                    plane: r.u32(),
                    first_vertex: r.u32(),
                    num_vertices: r.u32(),
                    texture: r.u32(),
                })
                .collect();
        }
        LumpKind::Vertices => level.vertices = records(kind, data)?.map(|(_, mut r)| r.vec3()).collect(),
        LumpKind::Portals => {
            level.portals = records(kind, data)?
                .map(|(_, mut r)| Portal {
                    leaves: [r.u32(), r.u32()],
                    plane: r.u32(),
                    first_vertex: r.u32(),
                    num_vertices: r.u32(),
                })
                .collect();
        }
        LumpKind::Models => {
            level.models = records(kind, data)?
                .map(|(_, mut r)| Model {
                    head_node: r.i32(),
                    mins: r.vec3(),
                    maxs: r.vec3(),
                    first_face: r.u32(),
                    num_faces: r.u32(),
                })
                .collect();
        }
        LumpKind::Clusters => {
            if data.len() != 4 {
                return Err(invalid(kind, 0, 0, format!("{} bytes, expected 4", data.len())));
            }
            level.num_clusters = Rec::new(data).u32();
        }
        LumpKind::PvsOffsets => level.pvs_offsets = records(kind, data)?.map(|(_, mut r)| r.u32()).collect(),
        LumpKind::PvsData => level.pvs_data = data.to_vec(),
        LumpKind::GvsCells => {
            level.gvs_cells = records(kind, data)?
                .map(|(_, mut r)| GvsCell {
                    mins: r.vec3(),
                    maxs: r.vec3(),
                    first_face: r.u32(),
                    num_faces: r.u32(),
                })
                .collect();
        }
        LumpKind::GvsFaces => level.gvs_faces = records(kind, data)?.map(|(_, mut r)| r.u32()).collect(),
        LumpKind::FaceDraw => {
            level.face_draw = records(kind, data)?
                .map(|(_, mut r)| FaceDraw {
                    s: [r.f32(), r.f32(), r.f32(), r.f32()],
                    t: [r.f32(), r.f32(), r.f32(), r.f32()],
                    flags: r.u32(),
                    styles: r.take(),
                    light_offset: r.i32(),
                })
                .collect();
        }
        LumpKind::TextureSizes => {
            level.texture_sizes = records(kind, data)?.map(|(_, mut r)| [r.u32(), r.u32()]).collect();
        }
        LumpKind::PortalFile => {
            level.portal_file = match data.len() {
                0 => None,
                8 => Some(Rec::new(data).u64()),
                n => return Err(invalid(kind, 0, 0, format!("{n} bytes, expected 0 or 8"))),
            };
        }
    }
    Ok(())
}
