//! Wavefront `.obj` scenes as one indexed triangle mesh, read through `tobj` from bytes (the
//! caller reads the file; `tobj` opens none, not even a material library).
//!
//! Every object and group of the file is merged into one [`TriMesh`]; polygons are triangulated as
//! fans by `tobj` (`triangulate`), and vertices are indexed once per distinct `v/vt/vn` triple
//! (`single_index`), so a position shared by faces with different normals may appear more than
//! once. Materials (`mtllib`) are never loaded. Points and lines are ignored: `p` and `l`
//! elements, and faces (`f`) of one or two vertices, which enclose no area. Such faces are not
//! errors (exporters write them for loose vertices and edges); they are skipped and counted in
//! [`TriMesh::skipped_faces`], which the compiler reports as a warning. A face of no vertex at all
//! is an error naming `file:line`.
//!
//! Coordinates are kept as written (no axis swap): the caller decides what "up" is. Every
//! coordinate must be finite with `|x| <=` [`WORLD_LIMIT`], and every index must be in range.
//! Before `tobj` sees the text, face indices are checked to be no larger in magnitude than the
//! number of lines (no valid file can use more), which also keeps `tobj`'s index arithmetic from
//! overflowing on hostile input.

use glam::DVec3;

use crate::geom::{Aabb, WORLD_LIMIT};

/// An indexed triangle mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions, in file units.
    pub positions: Vec<DVec3>,
    /// Triangles as indices into `positions`, in file winding order (counter-clockwise seen from
    /// the front for conventional `.obj` files).
    pub triangles: Vec<[u32; 3]>,
    /// Faces (`f` lines) of one or two vertices, skipped: they have no area.
    pub skipped_faces: usize,
}

impl TriMesh {
    /// The box around every position ([`Aabb::EMPTY`] for an empty mesh).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// The three corners of triangle `i`; `None` when `i` is out of range.
    pub fn triangle(&self, i: usize) -> Option<[DVec3; 3]> {
        let t = self.triangles.get(i)?;
        Some([
            *self.positions.get(t[0] as usize)?,
            *self.positions.get(t[1] as usize)?,
            *self.positions.get(t[2] as usize)?,
        ])
    }
}

/// What went wrong loading an `.obj`; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ObjError {
    /// A face index that no file of this size can hold (checked before `tobj` runs).
    #[error("{path}:{line}:{col}: face index `{token}` is out of range")]
    FaceIndex {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (characters).
        col: usize,
        /// The offending index text.
        token: String,
    },
    /// `tobj` rejected the text.
    #[error("{path}:{line}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line: the first line such that the text up to it fails to load.
        line: usize,
        /// The `tobj` error.
        source: tobj::LoadError,
    },
    /// A position that is not finite or beyond the world limit.
    #[error(
        "{path}: object `{object}`: its vertex {vertex} ({x}, {y}, {z}) is not finite or beyond ±{WORLD_LIMIT}"
    )]
    BadVertex {
        /// The file.
        path: String,
        /// The object (or group) name.
        object: String,
        /// Index of the vertex within the object.
        vertex: usize,
        /// The coordinates.
        x: f64,
        /// The coordinates.
        y: f64,
        /// The coordinates.
        z: f64,
    },
    /// A triangle index beyond the object's vertices, or a malformed index list.
    #[error("{path}: object `{object}`: triangle {triangle} has an invalid vertex index")]
    BadIndex {
        /// The file.
        path: String,
        /// The object (or group) name.
        object: String,
        /// Index of the triangle within the object.
        triangle: usize,
    },
    /// More vertices than a `u32` index can address.
    #[error("{path}: more than {} vertices", u32::MAX)]
    TooLarge {
        /// The file.
        path: String,
    },
}

/// Load `.obj` text from memory; `name` is used in errors.
pub fn load_from_bytes(bytes: &[u8], name: &str) -> Result<TriMesh, ObjError> {
    let skipped_faces = check_face_indices(bytes, name)?;
    let models = match run_tobj(bytes) {
        Ok(models) => models,
        Err(source) => {
            return Err(ObjError::Parse { path: name.to_string(), line: failing_line(bytes), source });
        }
    };
    let mut mesh = TriMesh { skipped_faces, ..TriMesh::default() };
    for model in &models {
        append(&mut mesh, model, name)?;
    }
    Ok(mesh)
}

fn run_tobj(bytes: &[u8]) -> Result<Vec<tobj::Model>, tobj::LoadError> {
    // Without `ignore_points` and `ignore_lines`, `tobj` would turn one- and two-vertex faces into
    // triangles of no area.
    let options =
        tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let mut reader = std::io::Cursor::new(bytes);
    tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default())).map(|(models, _)| models)
}

/// `tobj` does not say where it failed: find the first line `k` such that lines `1..=k` fail to
/// load, by bisection (only on the error path; `log2(lines)` more loads).
fn failing_line(bytes: &[u8]) -> usize {
    let ends: Vec<usize> = bytes
        .iter()
        .enumerate()
        .filter(|&(_, &b)| b == b'\n')
        .map(|(i, _)| i + 1)
        .chain([bytes.len()])
        .collect();
    let fails =
        |k: usize| ends.get(k - 1).is_none_or(|&end| run_tobj(bytes.get(..end).unwrap_or(bytes)).is_err());
    // Invariant: lines 1..=hi fail; lines 1..=lo - 1 load (or lo == 1).
    let (mut lo, mut hi) = (1, ends.len());
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if fails(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    hi
}

/// Reject face indices larger in magnitude than the number of lines: such a file cannot define
/// that many vertices, and huge indices would overflow `tobj`'s arithmetic. Returns the number of
/// faces of one or two vertices (which `tobj` is told to skip).
fn check_face_indices(bytes: &[u8], name: &str) -> Result<usize, ObjError> {
    let text = String::from_utf8_lossy(bytes);
    let limit = text.lines().count();
    let mut skipped = 0;
    for (l, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("f") {
            continue;
        }
        if (1..=2).contains(&words.clone().count()) {
            skipped += 1;
        }
        for word in words {
            for part in word.split('/').filter(|p| !p.is_empty()) {
                let digits = part.strip_prefix('-').unwrap_or(part);
                // Words that are not integers at all are `tobj`'s to report.
                let integer = !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit());
                let in_range = part.parse::<i64>().is_ok_and(|x| x.unsigned_abs() <= limit as u64);
                if integer && !in_range {
                    let offset = word.as_ptr() as usize - line.as_ptr() as usize;
                    let col = line.get(..offset).map_or(1, |s| s.chars().count() + 1);
                    return Err(ObjError::FaceIndex {
                        path: name.to_string(),
                        line: l + 1,
                        col,
                        token: part.chars().take(40).collect(),
                    });
                }
            }
        }
    }
    Ok(skipped)
}

/// Append one `tobj` model to `mesh`, validating it.
fn append(mesh: &mut TriMesh, model: &tobj::Model, name: &str) -> Result<(), ObjError> {
    let m = &model.mesh;
    let base = mesh.positions.len();
    let count = m.positions.len() / 3;
    if base + count > u32::MAX as usize {
        return Err(ObjError::TooLarge { path: name.to_string() });
    }
    mesh.positions.reserve(count);
    for (vertex, c) in m.positions.chunks_exact(3).enumerate() {
        let p = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
        if !p.is_finite() || p.abs().max_element() > WORLD_LIMIT {
            return Err(ObjError::BadVertex {
                path: name.to_string(),
                object: model.name.clone(),
                vertex,
                x: p.x,
                y: p.y,
                z: p.z,
            });
        }
        mesh.positions.push(p);
    }
    let bad = |triangle| ObjError::BadIndex { path: name.to_string(), object: model.name.clone(), triangle };
    if !m.indices.len().is_multiple_of(3) {
        return Err(bad(m.indices.len() / 3));
    }
    mesh.triangles.reserve(m.indices.len() / 3);
    for (triangle, t) in m.indices.chunks_exact(3).enumerate() {
        let mut tri = [0u32; 3];
        for (slot, &i) in tri.iter_mut().zip(t) {
            if i as usize >= count {
                return Err(bad(triangle));
            }
            // base + count <= u32::MAX was checked above.
            *slot = (base + i as usize) as u32;
        }
        mesh.triangles.push(tri);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD: &str = "# a unit quad and a triangle\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n\
                        o tri\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n";

    #[test]
    fn quads_are_triangulated_and_objects_merged() {
        let mesh = load_from_bytes(QUAD.as_bytes(), "q.obj").unwrap();
        assert_eq!(mesh.positions.len(), 7);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]]);
        assert_eq!(mesh.triangle(2), Some([DVec3::Z, DVec3::new(1.0, 0.0, 1.0), DVec3::new(0.0, 1.0, 1.0)]));
        assert_eq!(mesh.triangle(3), None);
        assert_eq!(mesh.bounds(), Aabb::new(DVec3::ZERO, DVec3::ONE));
    }

    #[test]
    fn out_of_range_indices_are_rejected() {
        let e = load_from_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "a.obj").unwrap_err();
        assert_eq!(e.to_string(), "a.obj:4");
        let cause = std::error::Error::source(&e).map(ToString::to_string).unwrap_or_default();
        assert!(cause.starts_with("face vertex index out of bounds"), "{cause}");
        let e =
            load_from_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", "a.obj").unwrap_err();
        assert!(matches!(e, ObjError::FaceIndex { line: 4, col: 7, .. }), "{e:?}");
        let e = load_from_bytes(b"v 0 0 0\nvt 0 0\nf 1/9223372036854775807 1/1 1/1\n", "a.obj").unwrap_err();
        assert!(matches!(e, ObjError::FaceIndex { line: 3, col: 3, .. }), "{e:?}");
    }

    #[test]
    fn bad_coordinates_are_rejected() {
        for text in ["v 0 0 NaN\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "v 0 0 2e6\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"] {
            let e = load_from_bytes(text.as_bytes(), "b.obj").unwrap_err();
            assert!(matches!(e, ObjError::BadVertex { vertex: 0, .. }), "{e:?}");
        }
        let e = load_from_bytes(b"v 0 0 0\nv 1 0 0\n# c\nv 0 0 x\nf 1 2 3\n", "b.obj").unwrap_err();
        assert!(matches!(e, ObjError::Parse { line: 4, .. }), "{e:?}");
        assert_eq!(e.to_string(), "b.obj:4");
        assert!(std::error::Error::source(&e).is_some(), "the cause is the error's source");
    }

    #[test]
    fn faces_of_one_or_two_vertices_are_skipped_and_counted() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1\nf 1 2\nf 1 2 3\nf 2 3\nl 1 2\np 1\n";
        let mesh = load_from_bytes(text.as_bytes(), "s.obj").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]], "only the real triangle is kept");
        assert_eq!(mesh.skipped_faces, 3);
        assert_eq!(load_from_bytes(QUAD.as_bytes(), "q.obj").unwrap().skipped_faces, 0);
        // Only degenerate faces: an empty mesh, every face counted.
        let mesh = load_from_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2\nf 2\n", "e.obj").unwrap();
        assert_eq!((mesh.triangles.len(), mesh.skipped_faces), (0, 2));
        // A face without any vertex is an error at its line.
        let e = load_from_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", "z.obj").unwrap_err();
        assert!(matches!(e, ObjError::Parse { line: 4, .. }), "{e:?}");
    }

    #[test]
    fn materials_are_not_loaded() {
        let text = format!("mtllib /etc/passwd\nusemtl x\n{QUAD}");
        assert_eq!(load_from_bytes(text.as_bytes(), "m.obj").unwrap().triangles.len(), 3);
    }

    mod hostile {
        use proptest::prelude::*;

        use super::super::*;
        use super::QUAD;

        proptest! {
            #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

            /// Byte edits of a valid file either load a valid mesh or fail; never panic.
            #[test]
            fn mutated_text_never_panics(
                edits in proptest::collection::vec((0usize..4096, any::<u8>(), 0u8..3), 1..8)
            ) {
                let mut bytes = QUAD.as_bytes().to_vec();
                crate::test_support::apply_edits(&mut bytes, &edits);
                if let Ok(mesh) = load_from_bytes(&bytes, "h.obj") {
                    for t in &mesh.triangles {
                        prop_assert!(t.iter().all(|&i| (i as usize) < mesh.positions.len()));
                    }
                    prop_assert!(mesh.positions.iter().all(|p| p.is_finite()));
                }
            }

            /// Random lines from the `.obj` vocabulary with random numbers.
            #[test]
            fn random_lines_never_panic(
                lines in proptest::collection::vec(
                    (prop_oneof![Just("v"), Just("vt"), Just("vn"), Just("f"), Just("l"), Just("p"),
                                 Just("o"), Just("g"), Just("usemtl"), Just("s"), Just("mtllib")],
                     proptest::collection::vec(
                         prop_oneof![any::<i64>().prop_map(|x| x.to_string()),
                                     (-10i64..10).prop_map(|x| x.to_string()),
                                     ((-10i64..10), (-10i64..10)).prop_map(|(a, b)| format!("{a}/{b}")),
                                     ((-10i64..10), (-10i64..10)).prop_map(|(a, b)| format!("{a}//{b}")),
                                     any::<f64>().prop_map(|x| x.to_string())],
                         0..6)),
                    0..30)
            ) {
                let text: String = lines.iter().map(|(k, w)| format!("{k} {}\n", w.join(" "))).collect();
                let _ = load_from_bytes(text.as_bytes(), "r.obj");
            }
        }
    }
}
