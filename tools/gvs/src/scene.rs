//! Triangle scenes for GVS: generated (`gen:<kind>:<size>`), `.obj` meshes, and the faces of a
//! compiled level (a `.slvl`, or a `.bsp` of any Quake-family game; fanned into triangles,
//! remembering which face each triangle came from); and [`load`], which picks one of them from a
//! scene argument.

use std::path::{Path, PathBuf};

use glam::Vec3;
use sightline_formats::Level;
use sightline_formats::bsp::{BspError, CompiledMap};
use sightline_formats::obj::ObjError;
use sightline_formats::slvl::SlvlError;
use sightline_job::input::{InputError, read_input};
use sightline_job::progress::Progress;

use super::geom::Cell;
use crate::scenegen::{self, SpecError};

/// A triangle soup with where it came from.
#[derive(Debug, Clone, Default)]
pub struct TriScene {
    /// The triangles.
    pub triangles: Vec<[Vec3; 3]>,
    /// For a level: the face index of every triangle.
    pub face_of: Option<Vec<u32>>,
    /// View cells the scene suggests (`--cell auto`).
    pub suggested: Vec<Cell>,
    /// Where a camera can stand (a generated scene's [`scenegen::Scene::open`]; empty: anywhere
    /// in the bounds).
    pub open: Vec<Cell>,
}

impl TriScene {
    /// Bounds of all triangles (a zero box at the origin when empty).
    pub fn bounds(&self) -> Cell {
        let mut lo = Vec3::INFINITY;
        let mut hi = Vec3::NEG_INFINITY;
        for t in &self.triangles {
            for p in t {
                if p.is_finite() {
                    lo = lo.min(*p);
                    hi = hi.max(*p);
                }
            }
        }
        if lo.cmpgt(hi).any() { Cell::new(Vec3::ZERO, Vec3::ZERO) } else { Cell::new(lo, hi) }
    }
}

/// A generated scene.
pub fn generated(kind: scenegen::Kind, size: u32, seed: u64) -> TriScene {
    let s = scenegen::generate(kind, size, seed);
    TriScene {
        triangles: s.triangles,
        face_of: None,
        suggested: s.cells.into_iter().map(|(a, b)| Cell::new(a, b)).collect(),
        open: s.open.into_iter().map(|(a, b)| Cell::new(a, b)).collect(),
    }
}

/// The faces of `level` fanned into triangles. Faces whose corners fall outside the vertex array
/// are skipped (a level read from disk has been validated, so this only guards hand-made ones).
///
/// A level's faces run clockwise seen from their front; the triangles run counter-clockwise seen
/// from the front, as in `.obj` meshes and the generated scenes, so that `(v1 - v0) × (v2 - v0)`
/// points to the side the face is seen from: neighbour probing casts most of its rays from that
/// side (with the faces' own order it probed every wall from behind, where no view cell of a
/// sealed level is, and missed walls of several hundred pixels in a view).
pub fn from_level(level: &Level) -> TriScene {
    let mut triangles = Vec::new();
    let mut face_of = Vec::new();
    for (fi, f) in level.faces.iter().enumerate() {
        let first = f.first_vertex as usize;
        let Some(vs) = level.vertices.get(first..first.saturating_add(f.num_vertices as usize)) else {
            continue;
        };
        let v = |k: usize| Vec3::from_array(vs[k]);
        for k in 1..vs.len().saturating_sub(1) {
            triangles.push([v(0), v(k + 1), v(k)]);
            face_of.push(fi as u32);
        }
    }
    TriScene { triangles, face_of: Some(face_of), ..TriScene::default() }
}

/// The open leaves of `level` as view cells, each shrunk by `margin` on every side (so the cell
/// does not touch the walls it is bounded by), but on an axis where the leaf is thinner than four
/// margins by a quarter of its width only, so that a thin leaf keeps half its thickness. (Shrunk
/// to its middle plane or line, as before, a leaf thinner than two margins gave a cell whose
/// random rays left from a few faces of zero area: one `e1m3` leaf missed a far wall it sees over a
/// third of its length, 1 083 wrong pixels in a 500 × 500 view; twelve levels' mean 0.190 → 0.098
/// wrong pixels per view, the largest 1 083 → 193.)
pub fn leaf_cells(level: &Level, margin: f32) -> Vec<Cell> {
    level
        .leaves
        .iter()
        .filter(|l| l.contents.is_open() && l.cluster >= 0)
        .map(|l| {
            let (a, b) = (Vec3::from_array(l.mins), Vec3::from_array(l.maxs));
            let m = ((b - a) * 0.25).min(Vec3::splat(margin)).max(Vec3::ZERO);
            Cell::new(a + m, b - m)
        })
        .collect()
}

/// Why [`load`] gives no scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// A `gen:` spec that does not parse.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// An `.obj` that does not load.
    #[error(transparent)]
    Obj(#[from] ObjError),
    /// A scene file that cannot be read, or is not a regular file (the error names it).
    #[error(transparent)]
    Read(#[from] InputError),
    /// A level file that is not a valid `.slvl`.
    #[error("{}", path.display())]
    Level {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: SlvlError,
    },
    /// A compiled map that does not read as a `.bsp` of any Quake-family game.
    #[error("{}", path.display())]
    Bsp {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: BspError,
    },
    /// Neither a `gen:` spec nor a file of a known kind.
    #[error("{0}: expected gen:<kind>:<size>, a .obj, a .slvl or a .bsp")]
    Input(String),
}

/// Load the scene `input` names, and the level when it is one: a generated scene
/// (`gen:<kind>:<size>`, see [`scenegen::parse_spec`], from `scene_seed`), an `.obj` mesh, a
/// `.slvl` level or a compiled `.bsp` of any Quake-family game (as [`CompiledMap::to_level`]
/// makes it a level), by the extension, in any case. Each repair of a `.bsp`'s stored bounds that
/// view cells use (an open leaf's, a model's) is a warning to `progress` naming the file.
pub fn load(
    input: &str,
    scene_seed: u64,
    progress: &dyn Progress,
) -> Result<(TriScene, Option<Level>), LoadError> {
    if let Some(spec) = scenegen::parse_spec(input) {
        let (kind, size) = spec?;
        return Ok((generated(kind, size, scene_seed), None));
    }
    let path = Path::new(input);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
    match ext.as_str() {
        "obj" => Ok((load_obj(path)?, None)),
        "slvl" | "bsp" => {
            let level = if ext == "bsp" { read_bsp(path, progress)? } else { read_level(path)? };
            Ok((from_level(&level), Some(level)))
        }
        _ => Err(LoadError::Input(input.to_string())),
    }
}

/// The triangles of the `.obj` mesh at `path` (triangles with a corner outside the vertex list
/// are skipped).
fn load_obj(path: &Path) -> Result<TriScene, LoadError> {
    let mesh = sightline_formats::obj::load_from_bytes(&read_input(path)?, &path.display().to_string())?;
    let triangles =
        (0..mesh.triangles.len()).filter_map(|i| mesh.triangle(i)).map(|t| t.map(|p| p.as_vec3())).collect();
    Ok(TriScene { triangles, ..TriScene::default() })
}

/// Read and validate the `.slvl` level at `path`.
fn read_level(path: &Path) -> Result<Level, LoadError> {
    let bytes = read_input(path)?;
    sightline_formats::slvl::read(&bytes)
        .map_err(|source| LoadError::Level { path: path.to_path_buf(), source })
}

/// Read the compiled map at `path` (any Quake-family game) as a level, and validate it as a
/// `.slvl` is validated when read; repairs of its bounds are warnings to `progress`.
fn read_bsp(path: &Path, progress: &dyn Progress) -> Result<Level, LoadError> {
    let bytes = read_input(path)?;
    let map =
        CompiledMap::read(bytes).map_err(|source| LoadError::Bsp { path: path.to_path_buf(), source })?;
    let (level, repairs) = map.to_level_with_repairs();
    for r in repairs {
        progress.warn(&format!("{}: {r}", path.display()));
    }
    sightline_formats::slvl::validate(&level)
        .map_err(|source| LoadError::Level { path: path.to_path_buf(), source })?;
    Ok(level)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_formats::Face;

    #[test]
    fn level_faces_fan_into_triangles() {
        let level = Level {
            vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            faces: vec![
                Face { plane: 0, first_vertex: 0, num_vertices: 4, texture: 0 },
                Face { plane: 0, first_vertex: 2, num_vertices: 9, texture: 0 },
            ],
            ..Level::default()
        };
        let s = from_level(&level);
        assert_eq!(s.triangles.len(), 2);
        assert_eq!(s.face_of, Some(vec![0, 0]));
    }

    #[test]
    fn leaf_cells_keep_half_of_a_thin_leaf() {
        let leaf = |mins: [f32; 3], maxs: [f32; 3], contents| sightline_formats::Leaf {
            contents,
            cluster: 0,
            mins,
            maxs,
            first_face: 0,
            num_faces: 0,
        };
        let level = Level {
            leaves: vec![
                leaf([0.0, 0.0, 0.0], [1.0, 10.0, 3.0], sightline_formats::Contents::Empty),
                leaf([0.0, 0.0, 0.0], [9.0, 9.0, 9.0], sightline_formats::Contents::Solid),
            ],
            ..Level::default()
        };
        let cells = leaf_cells(&level, 1.0);
        assert_eq!(cells.len(), 1);
        assert_eq!(cells[0].min, Vec3::new(0.25, 1.0, 0.75));
        assert_eq!(cells[0].max, Vec3::new(0.75, 9.0, 2.25));
    }

    #[test]
    fn a_bsp_that_does_not_read_names_the_file() {
        let dir = std::env::temp_dir().join(format!("sightline-gvs-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("broken.BSP");
        std::fs::write(&path, b"IBSP\x26\0\0\0 too short").expect("write");
        let err = load(path.to_str().expect("utf-8 path"), 0, &sightline_job::progress::NoProgress)
            .expect_err("a broken .bsp loads");
        std::fs::remove_dir_all(&dir).ok();
        assert!(matches!(&err, LoadError::Bsp { path: p, .. } if p.ends_with("broken.BSP")), "{err:?}");
        let err = load("scene.txt", 0, &sightline_job::progress::NoProgress).expect_err("a .txt loads");
        assert!(err.to_string().contains("a .slvl or a .bsp"), "{err}");
    }

    #[test]
    fn level_triangles_face_the_front_of_their_face() {
        // Clockwise seen from +z, the front of plane 0.
        let level = Level {
            vertices: vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
            planes: vec![sightline_formats::LevelPlane { normal: [0.0, 0.0, 1.0], dist: 0.0 }],
            faces: vec![Face { plane: 0, first_vertex: 0, num_vertices: 4, texture: 0 }],
            ..Level::default()
        };
        let s = from_level(&level);
        assert_eq!(s.triangles.len(), 2);
        for t in &s.triangles {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(n.z > 0.0 && n.x == 0.0 && n.y == 0.0, "{t:?} faces {n}");
        }
    }
}
