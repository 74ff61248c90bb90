//! Loading a [`World`] from `.slvl` or Quake-family `.bsp` bytes (Quake 1, Half-Life, Quake 2,
//! Quake 3), optionally with the `.prt` file that a Quake 1 BSP's compiler wrote, to give the
//! portal backend its portals. Two entry points: [`load_path`] (a file, and the portal file
//! beside it; [`load_path_with`] also tells a [`Progress`] what it had to repair) and
//! [`load_bytes`] (bytes in memory); both tell the format by its magic bytes.

use std::path::Path;

use sightline_formats::bsp::{CompiledMap, Parsed};
use sightline_formats::level::{Level, LevelPlane, Portal};
use sightline_formats::prt::{self, PortalFile, PrtFormat};
use sightline_formats::slvl;
use sightline_job::input::read_input;
use sightline_job::progress::{NoProgress, Progress};

use crate::error::LoadError;
use crate::pvs::PvsRows;
use crate::world::World;

/// Load a `.slvl` file's bytes.
fn load_slvl(bytes: &[u8]) -> Result<World, LoadError> {
    World::new(&slvl::read(bytes)?)
}

/// Load a Quake-family `.bsp` with its visdata, read through the one view of a compiled map
/// ([`CompiledMap::read`] tells the game by the first bytes) and made a level by
/// [`CompiledMap::to_level`]: Quake 1 and Half-Life (BSP29, BSP2, BSP2-RMQ, BSP30) leaf `i` of
/// the world is leaf `i` of the BSP and vis leaf `i` is cluster `i - 1`; Quake 2 (`IBSP` 38) and
/// Quake 3 (`IBSP` 46/47) leaves keep their clusters, and a Quake 2 world keeps the file's PHS
/// rows too ([`World::decode_phs`] decodes them; [`sightline_formats::bsp::q2::read`] checked
/// that they decode). The world has no portals. Stored bounds the level could not use as they
/// are were repaired ([`sightline_formats::bsp::bounds`]); each repair of bounds the runtime uses
/// is a warning to `progress`, naming `name`.
fn load_bsp(map: &CompiledMap, name: &str, progress: &dyn Progress) -> Result<World, LoadError> {
    world_of(map, level_of(map, name, progress))
}

/// The level of `map`, each repair of its bounds a warning to `progress` naming `name`.
fn level_of(map: &CompiledMap, name: &str, progress: &dyn Progress) -> Level {
    let (level, repairs) = map.to_level_with_repairs();
    for r in repairs {
        progress.warn(&format!("{name}: {r}"));
    }
    level
}

/// The world of `level`, made from `map`: with the stored PHS rows of a Quake 2 map.
fn world_of(map: &CompiledMap, level: Level) -> Result<World, LoadError> {
    match map.parsed() {
        Parsed::Quake2(file) => {
            let phs = file.vis.as_ref().and_then(|vis| {
                let num_clusters = u32::try_from(vis.num_clusters).ok()?;
                let offsets = vis.offsets.iter().map(|o| o[1]).collect();
                Some(PvsRows::from_parts(num_clusters, offsets, vis.data.clone()))
            });
            World::with_phs(&level, phs)
        }
        Parsed::Quake(_) | Parsed::Quake3(_) => World::new(&level),
    }
}

/// Load a Quake 1 or Half-Life `.bsp` and take its portals from the text of the `.prt` file its
/// compiler wrote.
fn load_bsp_with_prt(
    map: &CompiledMap,
    prt_text: &str,
    prt_name: &str,
    name: &str,
    progress: &dyn Progress,
) -> Result<World, LoadError> {
    let mut level = level_of(map, name, progress);
    let prt = prt::read(prt_text, prt_name)?;
    add_prt_portals(&mut level, &prt)?;
    world_of(map, level)
}

/// Load `.slvl` or `.bsp` bytes (any game of the family), told apart by their first four bytes.
/// No portal file is read: the portal backend is available for a `.slvl` with portals.
pub fn load_bytes(bytes: &[u8]) -> Result<World, LoadError> {
    if bytes.starts_with(&slvl::MAGIC) {
        load_slvl(bytes)
    } else {
        load_bsp(&CompiledMap::read(bytes.to_vec())?, "the .bsp", &NoProgress)
    }
}

/// Load a file. For a Quake 1 or Half-Life `.bsp`, the portal file beside it
/// ([`sightline_formats::prt::find_beside_bsp`], the rule `vis` follows too) is used when present
/// and in PRT1 form (`\n` or `\r\n` line breaks alike); Quake 2 and Quake 3 portal files name
/// clusters, not leaves, and are not read. Only a regular file is read
/// ([`sightline_job::input::read_input`]). Every error names the file: [`LoadError::Io`] by
/// itself, the others inside [`LoadError::File`].
pub fn load_path(path: &Path) -> Result<World, LoadError> {
    load_path_with(path, &NoProgress)
}

/// [`load_path`], telling `progress` (as warnings naming the file) what it repaired to load the
/// file: stored bounds of a `.bsp` the runtime uses (open leaves', models') that were not finite
/// or inverted ([`sightline_formats::bsp::bounds`]).
pub fn load_path_with(path: &Path, progress: &dyn Progress) -> Result<World, LoadError> {
    let name = path.display().to_string();
    let bytes = read_input(path)?;
    let in_file = |e: LoadError| match e {
        LoadError::Io(_) => e,
        other => LoadError::File { path: path.display().to_string(), source: Box::new(other) },
    };
    if bytes.starts_with(&slvl::MAGIC) {
        return load_slvl(&bytes).map_err(in_file);
    }
    let map = CompiledMap::read(bytes).map_err(|e| in_file(e.into()))?;
    // Quake 2 and Quake 3 portals join clusters, not leaves: the portal backend cannot use them.
    if let Parsed::Quake(_) = map.parsed()
        && let Some(prt_path) = sibling_prt(path)
        && let Ok(prt_bytes) = read_input(&prt_path)
        && let text = String::from_utf8_lossy(&prt_bytes)
        && PrtFormat::of_text(&text) == Some(PrtFormat::Prt1)
    {
        let prt_name = prt_path.display().to_string();
        // A portal file that does not fit the level is named as well (syntax errors name it).
        let in_prt = |e: LoadError| match e {
            LoadError::Prt(_) => LoadError::File { path: prt_name.clone(), source: Box::new(e) },
            other => other,
        };
        return load_bsp_with_prt(&map, &text, &prt_name, &name, progress).map_err(in_prt).map_err(in_file);
    }
    load_bsp(&map, &name, progress).map_err(in_file)
}

/// The portal file beside a `.bsp` that exists, by the one rule every reader follows
/// ([`sightline_formats::prt::find_beside_bsp`]): `NAME.prt` for `NAME.bsp`; `NAME.vis.prt`, else
/// `NAME.prt`, for `NAME.vis.bsp`. `None` when there is none (or the name does not end in `.bsp`).
fn sibling_prt(path: &Path) -> Option<std::path::PathBuf> {
    prt::find_beside_bsp(path)
}

/// Append the portals of a PRT1 file to a Quake 1 level made by [`CompiledMap::to_level`]: vis leaf `i` of the
/// portal file is leaf `i + 1` of the level, and the winding's plane (which faces into its first
/// leaf) becomes the portal's plane, so the level's convention (normal into `leaves[0]`) holds.
fn add_prt_portals(level: &mut Level, prt: &PortalFile) -> Result<(), LoadError> {
    if prt.format != PrtFormat::Prt1 {
        return Err(LoadError::Prt(format!(
            "the portal backend needs leaf portals (PRT1); this file is {:?} (compile without detail)",
            prt.format
        )));
    }
    let visleafs = level.leaves.len().saturating_sub(1);
    if prt.num_leaves as usize > visleafs {
        return Err(LoadError::Prt(format!("{} portal leaves for {visleafs} BSP leaves", prt.num_leaves)));
    }
    for (i, p) in prt.portals.iter().enumerate() {
        let plane = p
            .winding
            .plane()
            .ok_or_else(|| LoadError::Prt(format!("portal {i} has a degenerate winding")))?;
        level.planes.push(LevelPlane { normal: plane.normal.as_vec3().to_array(), dist: plane.dist as f32 });
        let first_vertex = level.vertices.len() as u32;
        level.vertices.extend(p.winding.points.iter().map(|v| v.as_vec3().to_array()));
        level.portals.push(Portal {
            leaves: [p.leaves[0] + 1, p.leaves[1] + 1],
            plane: level.planes.len() as u32 - 1,
            first_vertex,
            num_vertices: p.winding.points.len() as u32,
        });
    }
    Ok(())
}
