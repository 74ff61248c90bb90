//! A [`VisResult`] stored the way files hold a PVS: per cluster in a [`Level`] ([`store_pvs`]),
//! per vis leaf in a Quake `.bsp` ([`write_into_bsp`]), a `.vis` file ([`Rows::vis_file`]) or an
//! engine's external `.vis` record ([`vispatch_record`]); and the input of vis on a Quake map, a
//! `.bsp` with the `.prt` beside it or with portals rebuilt from its tree ([`VisInput`]).
//!
//! # Conventions
//! - Rows are uncompressed in Quake's byte layout ([`sightline_formats::bits::bytes`]) and
//!   compressed with [`sightline_formats::rle`].
//! - Drop-in rules for a `.bsp` (as the reference vis): vis leaf `j` of the portal file is BSP
//!   leaf `j + 1` and owns PVS row `j`; leaves of one cluster (a PRT2 cluster, a VHLT portal
//!   leaf) share one compressed row, and identical rows are stored once, at the offset of their
//!   first occurrence in leaf order. Every vis leaf's ambient sound levels (water, sky, slime,
//!   lava) become 255 when its PVS holds a face whose texture makes that sound
//!   ([`sightline_formats::texture`]), else 0. Leaves that are not vis leaves keep their
//!   `visofs` and ambient levels.
//! - Half-Life (BSP30) is written the same way, ambient levels included: ericw-tools' vis fills
//!   them for BSP30 too, while SDHLT's `hlvis` leaves them 0, which
//!   `-noambient` reproduces.
//! - Ambient options ([`AmbientOptions`], `vis -noambient…`): a sound switched off is 0 in every
//!   vis leaf; faces whose texinfo ericw-tools' qbsp flagged `noambient` in `NAME.texinfo.json`
//!   beside the `.bsp` ([`sightline_formats::texinfo_json`], read by [`VisInput::read`]) make no
//!   sound, as in ericw-tools' vis. A side file naming a texinfo the `.bsp` lacks belongs to
//!   another compile and is ignored, as ericw-tools does ([`TexinfoSide::matches`]).
//! - Far plane ([`cluster_boxes`] for [`crate::vis::farplane`]): a cluster's box holds the
//!   `mins`/`maxs` of its BSP leaves, grown by [`LEAF_BOUNDS_SLACK`] (BSP29 stores them as
//!   integers), and every portal winding of the cluster.
//! - A level stores one row per cluster, in cluster order, without sharing.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use sightline_formats::Level;
use sightline_formats::bits;
use sightline_formats::bsp::{self, Bsp, BspError};
use sightline_formats::geom::Aabb;
use sightline_formats::prt::{self, PortalFile, PrtError};
use sightline_formats::rle;
use sightline_formats::texinfo_json::{self, TexinfoJson, TexinfoJsonError};
use sightline_formats::texture::TextureKind;
use sightline_formats::visfile::{self, VisFileError};
use sightline_formats::vispatch::{VisPatchError, VisPatchRecord};
use sightline_job::input::{InputError, read_input};
use thiserror::Error;

use crate::bsp_portals::{self, BspPortalOptions, BspPortalStats, BspPortalsError};
use crate::vis::VisResult;

/// Why vis input could not be read or its rows not be stored.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum VisdataError {
    /// A file could not be read ([`read_input`]: a regular file only; the error names it).
    #[error(transparent)]
    Read(#[from] InputError),
    /// The `.bsp` does not parse.
    #[error("{}: invalid BSP", path.display())]
    Bsp {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: BspError,
    },
    /// The `.bsp`'s lumps overlap where writing visdata needs them apart
    /// ([`bsp::check_vis_layout`]); found when reading, before any work.
    #[error("{}: vis cannot write into this BSP", path.display())]
    Layout {
        /// The file.
        path: PathBuf,
        /// Which lumps overlap, with their byte ranges.
        #[source]
        source: BspError,
    },
    /// No `.prt` beside a `.bsp` ([`prt::beside_bsp`] lists where it is looked for).
    #[error(
        "no portal file beside {}: looked for {}; vis needs the portal file your BSP compiler writes beside the .bsp (none is written when the map leaks), or rebuild the portals from the BSP's own tree with `sightline vis --portals-from-bsp {}`",
        bsp.display(),
        tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" and "),
        bsp.display()
    )]
    PrtMissing {
        /// The `.bsp`.
        bsp: PathBuf,
        /// The portal files looked for, in order.
        tried: Vec<PathBuf>,
    },
    /// The portal file does not parse (the error names the file).
    #[error(transparent)]
    Prt(#[from] PrtError),
    /// The `.bsp` and the `.prt` disagree on the number of vis leaves.
    #[error(
        "{} has {bsp_leaves} vis leaves but {} has {prt_leaves}: they come from different compiles",
        bsp.display(),
        prt.display()
    )]
    Mismatch {
        /// The `.bsp`.
        bsp: PathBuf,
        /// Its vis leaves (`visleafs` of the world model).
        bsp_leaves: usize,
        /// The `.prt`.
        prt: PathBuf,
        /// Its vis leaves.
        prt_leaves: u32,
    },
    /// A VHLT portal file without its leaf-count lines (rewritten by `hlvis`'s FixPrt) whose
    /// portal leaves are not one per vis leaf of the `.bsp`: which leaves each holds is lost.
    #[error(
        "{} has no leaf-count lines (hlvis's FixPrt removed them), so its {portal_leaves} portal leaves cannot be matched to the {bsp_leaves} vis leaves of {}; vis needs the .prt as hlbsp wrote it (or hlvis -nofixprt)",
        prt.display(),
        bsp.display()
    )]
    FixedPrt {
        /// The `.bsp`.
        bsp: PathBuf,
        /// Its vis leaves.
        bsp_leaves: usize,
        /// The `.prt`.
        prt: PathBuf,
        /// Its portal leaves.
        portal_leaves: u32,
    },
    /// The `.bsp` could not take the new visdata (for example more than 2 GiB of it).
    #[error(transparent)]
    BspWrite(BspError),
    /// The rows do not fit a `.vis` file.
    #[error(transparent)]
    VisFile(#[from] VisFileError),
    /// The `NAME.texinfo.json` beside the `.bsp` does not parse (the error names the file).
    #[error(transparent)]
    TexinfoJson(#[from] TexinfoJsonError),
    /// Portals could not be rebuilt from the `.bsp`'s tree ([`VisInput::from_bsp_tree`]).
    #[error("{}: cannot rebuild portals from its tree", path.display())]
    Portals {
        /// The file.
        path: PathBuf,
        /// What is wrong with its tree.
        #[source]
        source: BspPortalsError,
    },
    /// The external `.vis` record could not be made ([`vispatch_record`]).
    #[error(transparent)]
    VisPatch(#[from] VisPatchError),
}

/// A Quake `.bsp`, as read for vis to write into.
#[derive(Debug, Clone)]
pub struct BspInput {
    /// The file.
    pub path: PathBuf,
    /// Its bytes (every lump but visibility and leaves is written back unchanged).
    pub bytes: Vec<u8>,
    /// Its parse.
    pub bsp: Bsp,
    /// ericw-tools' `NAME.texinfo.json` beside it, when there is one.
    pub texinfo_json: Option<TexinfoSide>,
}

/// The `NAME.texinfo.json` ericw-tools' qbsp writes beside `NAME.bsp`, as read for vis.
#[derive(Debug, Clone)]
pub struct TexinfoSide {
    /// The file.
    pub path: PathBuf,
    /// What it says.
    pub flags: TexinfoJson,
    /// False when it names a texinfo the `.bsp` does not have: it comes from another compile and,
    /// as in ericw-tools' vis, its flags are not used.
    pub matches: bool,
}

/// What makes ambient sound levels ([`ambient_levels_with`]). The default is Quake's vis: every
/// sound on, every face counts.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AmbientOptions {
    /// Sounds switched off (`-noambientwater`, `-noambientsky`, `-noambientslime`,
    /// `-noambientlava`), indexed by [`sightline_formats::texture::Ambient::index`]: 0 in every
    /// vis leaf.
    pub off: [bool; 4],
    /// Texinfo numbers whose faces make no sound (`_noambient`, from `NAME.texinfo.json`).
    pub silent_texinfo: Vec<u32>,
}

impl AmbientOptions {
    /// Every sound off (`-noambient`): every vis leaf's four levels are 0.
    pub fn none() -> Self {
        Self { off: [true; 4], silent_texinfo: Vec::new() }
    }
}

/// What vis reads: a portal file, and the `.bsp` it belongs to when vis writes into one.
#[derive(Debug, Clone)]
pub struct VisInput {
    /// The portal file: the one beside the `.bsp` ([`prt::beside_bsp`]), the input itself, or
    /// the `.bsp` when the portals were rebuilt from its tree ([`VisInput::from_bsp_tree`]).
    pub prt_path: PathBuf,
    /// Its content.
    pub prt: PortalFile,
    /// The `.bsp`, when the input is one.
    pub bsp: Option<BspInput>,
}

impl VisInput {
    /// Reads `path`: a `.bsp` (by extension, any case) and the `.prt` beside it
    /// ([`prt::beside_bsp`]: `NAME.prt` for `NAME.bsp`; `NAME.vis.prt`, else `NAME.prt`, for
    /// `NAME.vis.bsp`, the rule the runtime loader follows too), which must have as many vis
    /// leaves; or a portal file alone. A `.bsp` whose lumps overlap where vis would write
    /// ([`bsp::check_vis_layout`]) is refused here, before any work.
    pub fn read(path: &Path) -> Result<Self, VisdataError> {
        Self::from_bytes(path, read_input(path)?)
    }

    /// [`VisInput::read`] of the file at `path` whose bytes the caller has read (`bytes`).
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Self, VisdataError> {
        let is_bsp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp"));
        let (bsp, prt_path, bytes) = if is_bsp {
            let bsp = BspInput::from_bytes(path, bytes)?;
            let tried = prt::beside_bsp(path);
            // The first that exists, whatever it is: one that is not a regular file is refused
            // by name rather than passed over.
            let Some(prt_path) = tried.iter().find(|p| p.exists()).cloned() else {
                return Err(VisdataError::PrtMissing { bsp: path.into(), tried });
            };
            let prt_bytes = read_input(&prt_path)?;
            (Some(bsp), prt_path, prt_bytes)
        } else {
            (None, path.to_path_buf(), bytes)
        };
        let prt = prt::read_bytes(&bytes, &prt_path.display().to_string())?;
        if let Some(b) = &bsp
            && b.bsp.visleafs() != prt.num_leaves as usize
        {
            if prt.format == prt::PrtFormat::VhltFixed {
                return Err(VisdataError::FixedPrt {
                    bsp: b.path.clone(),
                    bsp_leaves: b.bsp.visleafs(),
                    prt: prt_path,
                    portal_leaves: prt.num_clusters,
                });
            }
            return Err(VisdataError::Mismatch {
                bsp: b.path.clone(),
                bsp_leaves: b.bsp.visleafs(),
                prt: prt_path,
                prt_leaves: prt.num_leaves,
            });
        }
        Ok(Self { prt_path, prt, bsp })
    }

    /// Reads the `.bsp` at `path` alone and rebuilds its portals from its world tree
    /// ([`bsp_portals::build`] with `opts`); a portal file beside it is not read.
    pub fn from_bsp_tree(
        path: &Path,
        opts: BspPortalOptions,
    ) -> Result<(Self, BspPortalStats), VisdataError> {
        Self::from_bsp_tree_of(BspInput::read(path)?, opts)
    }

    /// [`VisInput::from_bsp_tree`] of a `.bsp` already read.
    pub fn from_bsp_tree_of(
        input: BspInput,
        opts: BspPortalOptions,
    ) -> Result<(Self, BspPortalStats), VisdataError> {
        let path = input.path.clone();
        let built = bsp_portals::build(&input.bsp, opts)
            .map_err(|source| VisdataError::Portals { path: path.clone(), source })?;
        Ok((Self { prt_path: path, prt: built.prt, bsp: Some(input) }, built.stats))
    }

    /// The ambient options of a run that switches off the sounds `off` (see
    /// [`AmbientOptions::off`]), with the `noambient` texinfos of the `.bsp`'s `NAME.texinfo.json`
    /// when it has one that matches.
    pub fn ambient_options(&self, off: [bool; 4]) -> AmbientOptions {
        let silent_texinfo = match self.bsp.as_ref().and_then(|b| b.texinfo_json.as_ref()) {
            Some(side) if side.matches => side.flags.noambient.clone(),
            _ => Vec::new(),
        };
        AmbientOptions { off, silent_texinfo }
    }
}

impl BspInput {
    /// Reads the `.bsp` at `path`, refusing one whose lumps overlap where vis would write
    /// ([`bsp::check_vis_layout`]), with the `NAME.texinfo.json` beside it when there is one.
    pub fn read(path: &Path) -> Result<Self, VisdataError> {
        Self::from_bytes(path, read_input(path)?)
    }

    /// [`BspInput::read`] of the file at `path` whose bytes the caller has read (`bytes`).
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Self, VisdataError> {
        let bsp = bsp::read(&bytes).map_err(|source| VisdataError::Bsp { path: path.into(), source })?;
        bsp::check_vis_layout(&bsp.lumps)
            .map_err(|source| VisdataError::Layout { path: path.into(), source })?;
        let texinfo_json = read_texinfo_side(path, &bsp)?;
        Ok(Self { path: path.into(), bytes, bsp, texinfo_json })
    }
}

/// Reads the `NAME.texinfo.json` beside the `.bsp` at `path` (parsed as `bsp`); `None` when there
/// is none.
fn read_texinfo_side(path: &Path, bsp: &Bsp) -> Result<Option<TexinfoSide>, VisdataError> {
    let side = texinfo_json::path_beside(path);
    let bytes = match read_input(&side) {
        Ok(b) => b,
        Err(e) if e.is_not_found() => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    let flags = texinfo_json::read(&bytes, &side.display().to_string())?;
    let matches = flags.max_texinfo.is_none_or(|t| (t as usize) < bsp.texinfo.len());
    Ok(Some(TexinfoSide { path: side, flags, matches }))
}

/// Compressed PVS rows, one per vis leaf: leaves of a cluster share one row, identical rows are
/// stored once.
#[derive(Debug, Clone)]
pub struct Rows {
    /// Row bytes back to back.
    pub data: Vec<u8>,
    /// Offset of each vis leaf's row in `data`.
    pub leaf_offsets: Vec<u32>,
    /// Uncompressed row length.
    pub row_bytes: usize,
}

impl Rows {
    /// Compress the rows of `result` (leaves of a cluster share one row, and clusters with the
    /// same cluster row, as those `--coarsen` merged, share its leaf row, built once).
    pub fn new(result: &VisResult) -> Self {
        let mut data = Vec::new();
        let mut seen: HashMap<Vec<u8>, u32> = HashMap::new();
        let mut of_row: HashMap<&[u64], u32> = HashMap::new();
        let mut cluster_offset: Vec<Option<u32>> = vec![None; result.num_clusters()];
        let mut leaf_offsets = Vec::with_capacity(result.num_leaves());
        let mut row = Vec::new();
        let mut packed = Vec::new();
        for (leaf, &c) in result.leaf_clusters().iter().enumerate() {
            let slot = &mut cluster_offset[c as usize];
            let ofs = match *slot {
                Some(o) => o,
                None => {
                    let o = *of_row.entry(result.cluster_row(c as usize)).or_insert_with(|| {
                        result.leaf_row_bytes(leaf, &mut row);
                        packed.clear();
                        rle::encode_row(&row, &mut packed);
                        *seen.entry(packed.clone()).or_insert_with(|| {
                            let o = data.len() as u32;
                            data.extend_from_slice(&packed);
                            o
                        })
                    });
                    *slot = Some(o);
                    o
                }
            };
            leaf_offsets.push(ofs);
        }
        Self { data, leaf_offsets, row_bytes: bits::bytes::len(result.num_leaves()) }
    }

    /// The `.vis` file of these rows ([`sightline_formats::visfile`]).
    pub fn vis_file(&self) -> Result<Vec<u8>, VisdataError> {
        Ok(visfile::write(self.row_bytes, &self.leaf_offsets, &self.data)?)
    }
}

/// Ambient levels of every BSP leaf: vis leaves from their PVS (255 for each sound some face of a
/// visible leaf makes, else 0), other leaves unchanged. As [`ambient_levels_with`] and the
/// default options.
pub fn ambient_levels(bsp: &Bsp, result: &VisResult) -> Vec<[u8; 4]> {
    ambient_levels_with(bsp, result, &AmbientOptions::default())
}

/// Ambient levels of every BSP leaf: vis leaves from their PVS (255 for each sound some face of a
/// visible leaf makes, unless `opts` switches the sound off or silences the face's texinfo; else
/// 0), other leaves unchanged.
pub fn ambient_levels_with(bsp: &Bsp, result: &VisResult, opts: &AmbientOptions) -> Vec<[u8; 4]> {
    let mut silent = vec![false; bsp.texinfo.len()];
    for &t in &opts.silent_texinfo {
        if let Some(s) = silent.get_mut(t as usize) {
            *s = true;
        }
    }
    // Sounds the faces of each cluster's vis leaves make.
    let mut makes = vec![[false; 4]; result.num_clusters()];
    for (j, &c) in result.leaf_clusters().iter().enumerate() {
        let Some(leaf) = bsp.leaves.get(j + 1) else { continue };
        let first = leaf.first_marksurface as usize;
        let marks = bsp.marksurfaces.get(first..first + leaf.num_marksurfaces as usize).unwrap_or_default();
        for &m in marks {
            let sound = bsp
                .faces
                .get(m as usize)
                .filter(|f| !silent.get(f.texinfo as usize).copied().unwrap_or(false))
                .and_then(|f| TextureKind::of(bsp.face_texture_name(f)).ambient());
            if let Some(sound) = sound.filter(|a| !opts.off[a.index()]) {
                makes[c as usize][sound.index()] = true;
            }
        }
    }
    // A leaf hears what any leaf of a cluster its cluster sees makes.
    let hears: Vec<[u8; 4]> = (0..result.num_clusters())
        .map(|c| {
            let mut s = [false; 4];
            for k in bits::ones(result.cluster_row(c)) {
                for (a, b) in s.iter_mut().zip(&makes[k]) {
                    *a |= *b;
                }
            }
            s.map(|on| if on { 255 } else { 0 })
        })
        .collect();
    let mut out: Vec<[u8; 4]> = bsp.leaves.iter().map(|l| l.ambient).collect();
    for (j, &c) in result.leaf_clusters().iter().enumerate() {
        if let Some(slot) = out.get_mut(j + 1) {
            *slot = hears[c as usize];
        }
    }
    out
}

/// The `.bsp` bytes `original` (parsed as `bsp`) with the visdata of `rows`, every vis leaf's
/// `visofs` pointing at its row ([`bsp::write_vis_rows`]), and ambient levels from
/// [`ambient_levels`]. As [`write_into_bsp_with`] and the default ambient options.
pub fn write_into_bsp(
    original: &[u8],
    bsp: &Bsp,
    result: &VisResult,
    rows: &Rows,
) -> Result<Vec<u8>, VisdataError> {
    write_into_bsp_with(original, bsp, result, rows, &AmbientOptions::default())
}

/// As [`write_into_bsp`], with ambient levels from [`ambient_levels_with`] and `ambient`.
pub fn write_into_bsp_with(
    original: &[u8],
    bsp: &Bsp,
    result: &VisResult,
    rows: &Rows,
    ambient: &AmbientOptions,
) -> Result<Vec<u8>, VisdataError> {
    let levels = ambient_levels_with(bsp, result, ambient);
    bsp::write_vis_rows(original, bsp, &rows.data, &rows.leaf_offsets, Some(&levels))
        .map_err(VisdataError::BspWrite)
}

/// The external `.vis` record ([`sightline_formats::vispatch`]) named `map_name` that gives the
/// BSP29 file `original` (parsed as `bsp`) the PVS of `rows`: the visibility and leaf lumps that
/// [`write_into_bsp_with`] would write into it (rows, `visofs`, ambient levels), while the file
/// itself stays as it is.
pub fn vispatch_record(
    map_name: &str,
    original: &[u8],
    bsp: &Bsp,
    result: &VisResult,
    rows: &Rows,
    ambient: &AmbientOptions,
) -> Result<VisPatchRecord, VisdataError> {
    if bsp.version != bsp::BspVersion::Bsp29 {
        return Err(VisPatchError::NotBsp29 { version: bsp.version.name() }.into());
    }
    let vised = write_into_bsp_with(original, bsp, result, rows, ambient)?;
    Ok(VisPatchRecord::from_bsp29(map_name, &vised)?)
}

/// How far a BSP leaf's stored `mins`/`maxs` are grown for [`cluster_boxes`]: BSP29 and BSP2-RMQ
/// store them as integers, which compilers round (or truncate) from the real bounds.
pub const LEAF_BOUNDS_SLACK: f64 = 1.0;

/// One box per cluster of `prt` holding every point of its leaves, for
/// [`crate::vis::farplane::cull`]: the union of its leaves' BSP bounds (vis leaf `j` is BSP leaf
/// `j + 1`), grown by [`LEAF_BOUNDS_SLACK`], and of its portal windings. A cluster with a leaf the
/// `.bsp` lacks, or whose stored bounds are not finite or inverted, gets an unbounded box (never
/// culled).
pub fn cluster_boxes(bsp: &Bsp, prt: &PortalFile) -> Vec<Aabb> {
    let leaves = prt.leaf_clusters.iter().enumerate().map(|(j, &c)| {
        let bounds = bsp.leaves.get(j + 1).map(|l| (l.mins, l.maxs));
        (c as usize, bounds)
    });
    cluster_boxes_from(prt, leaves)
}

/// [`cluster_boxes`] for a level whose clusters are the portal file's (a Quake 2 file through
/// `bsp::q2::to_level`, whose PRT1 names clusters): the union, per cluster, of the bounds of
/// every level leaf in it (solid leaves, cluster -1, skipped) and of its portal windings. A
/// cluster no leaf names gets an unbounded box.
pub fn level_cluster_boxes(level: &Level, prt: &PortalFile) -> Vec<Aabb> {
    let leaves = level
        .leaves
        .iter()
        .filter_map(|l| usize::try_from(l.cluster).ok().map(|c| (c, Some((l.mins, l.maxs)))));
    cluster_boxes_from(prt, leaves)
}

/// One box per cluster of `prt` from `(cluster, leaf bounds)` pairs (`None`: the leaf's bounds
/// are unknown) and the portal windings; clusters no pair names, or with a leaf of unknown,
/// non-finite or inverted bounds (compilers store cleared bounds for a leaf they never sized),
/// are unbounded. Leaf boxes grow by [`LEAF_BOUNDS_SLACK`].
fn cluster_boxes_from(
    prt: &PortalFile,
    leaves: impl Iterator<Item = (usize, Option<([f32; 3], [f32; 3])>)>,
) -> Vec<Aabb> {
    let unbounded = Aabb::new(DVec3::NEG_INFINITY, DVec3::INFINITY);
    let n = prt.num_clusters as usize;
    let mut boxes = vec![Aabb::EMPTY; n];
    let mut named = vec![false; n];
    for (c, bounds) in leaves {
        let Some(slot) = boxes.get_mut(c) else { continue };
        named[c] = true;
        let leaf_box = bounds
            .filter(|&(lo, hi)| bsp::bounds::usable(lo, hi))
            .map(|(lo, hi)| Aabb::new(DVec3::from(lo.map(f64::from)), DVec3::from(hi.map(f64::from))))
            .map_or(unbounded, |b| b.expanded(LEAF_BOUNDS_SLACK));
        *slot = slot.union(&leaf_box);
    }
    for (slot, named) in boxes.iter_mut().zip(named) {
        if !named {
            *slot = unbounded;
        }
    }
    for p in &prt.portals {
        let w = p.winding.bounds();
        for &c in &p.leaves {
            if let Some(slot) = boxes.get_mut(c as usize) {
                *slot = slot.union(&w);
            }
        }
    }
    boxes
}

/// Store vis rows in `level`: one Quake-RLE row per cluster (see [`Level`]'s conventions).
pub fn store_pvs(level: &mut Level, result: &VisResult) {
    let clusters = result.num_clusters();
    let row_bytes = bits::bytes::len(clusters);
    let mut bytes = Vec::with_capacity(row_bytes + 8);
    level.pvs_offsets.clear();
    level.pvs_data.clear();
    for c in 0..clusters {
        bits::to_bytes(result.cluster_row(c), row_bytes, &mut bytes);
        level.pvs_offsets.push(level.pvs_data.len() as u32);
        rle::encode_row(&bytes, &mut level.pvs_data);
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use sightline_formats::geom::Winding;
    use sightline_formats::prt::{PrtFormat, PrtPortal};

    use super::*;
    use crate::vis::{self, VisOptions};

    /// Three vis leaves in two clusters (leaves 0 and 1 form cluster 0) joined by one square
    /// portal: everything sees everything.
    fn two_clusters() -> VisResult {
        let square = Winding::new(vec![
            DVec3::new(64.0, 0.0, 0.0),
            DVec3::new(64.0, 0.0, 32.0),
            DVec3::new(64.0, 32.0, 32.0),
            DVec3::new(64.0, 32.0, 0.0),
        ]);
        let prt = PortalFile {
            format: PrtFormat::Prt2,
            num_leaves: 3,
            num_clusters: 2,
            portals: vec![PrtPortal { leaves: [0, 1], winding: square }],
            leaf_clusters: vec![0, 0, 1],
        };
        vis::run(&prt, &VisOptions::default(), &sightline_job::progress::NoProgress).expect("vis")
    }

    #[test]
    fn identical_rows_are_stored_once_and_clusters_each_get_one() {
        let result = two_clusters();
        assert!((0..3).all(|a| (0..3).all(|b| result.leaf_sees(a, b))));
        let rows = Rows::new(&result);
        // One row `0b111` for every leaf: compressed, the single byte 7.
        assert_eq!(
            (rows.data.as_slice(), rows.leaf_offsets.as_slice(), rows.row_bytes),
            (&[7u8][..], &[0, 0, 0][..], 1)
        );
        let file = visfile::read(&rows.vis_file().expect("small")).expect("reads back");
        assert_eq!(
            (file.row_bytes, file.leaf_offsets, file.data),
            (1, rows.leaf_offsets.clone(), rows.data.clone())
        );
        // A level keeps one row per cluster, unshared: `0b11` twice.
        let mut level = Level::default();
        store_pvs(&mut level, &result);
        assert_eq!((level.pvs_offsets.as_slice(), level.pvs_data.as_slice()), (&[0, 1][..], &[3u8, 3][..]));
    }

    /// A fresh temp dir holding a copy of the shared map `name` (`.bsp`, `.prt`, and its
    /// `.texinfo.json` when `with_side`) as `m.*`; `None` when the shared maps are absent.
    fn copy_shared(name: &str, tag: &str, with_side: bool) -> Option<(PathBuf, PathBuf)> {
        let src = sightline_tests::shared_maps()?.join(name);
        if !src.is_file() {
            return None;
        }
        let dir = std::env::temp_dir().join(format!("sightline-visdata-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        std::fs::copy(&src, dir.join("m.bsp")).expect("copy");
        std::fs::copy(src.with_extension("prt"), dir.join("m.prt")).expect("copy");
        if with_side {
            std::fs::copy(src.with_extension("texinfo.json"), dir.join("m.texinfo.json")).expect("copy");
        }
        Some((dir.join("m.bsp"), src))
    }

    const NOAMBIENT_MAP: &str = "ericw-testmaps/q1_vis_noambient_func_group.standin.bsp";

    #[test]
    fn noambient_texinfos_and_switched_off_sounds_shape_ambient_levels_as_ericw_vis() {
        let Some((bsp_path, src)) = copy_shared(NOAMBIENT_MAP, "ambient", true) else {
            eprintln!("note: {NOAMBIENT_MAP} not found; skipped");
            return;
        };
        let input = VisInput::read(&bsp_path).expect("reads with its side file");
        let b = input.bsp.as_ref().expect("a .bsp");
        let side = b.texinfo_json.as_ref().expect("the side file is read");
        assert!(side.matches && side.flags.noambient == [4], "{side:?}");
        let result = vis::run(
            &input.prt,
            &VisOptions { threads: 1, ..VisOptions::default() },
            &sightline_job::progress::NoProgress,
        )
        .expect("vis");

        let ericw =
            bsp::read(&std::fs::read(src.with_extension("ericw.bsp")).expect("ericw output")).expect("bsp");
        let reference: Vec<[u8; 4]> = ericw.leaves.iter().map(|l| l.ambient).collect();
        let levels = ambient_levels_with(&b.bsp, &result, &input.ambient_options([false; 4]));
        assert_eq!(levels, reference, "the func_group's sky is silent, as in ericw-tools' vis");
        let plain = ambient_levels(&b.bsp, &result);
        assert!(
            plain.iter().zip(&levels).any(|(p, l)| p[1] == 255 && l[1] == 0),
            "without the flags it sounds"
        );

        let none = ambient_levels_with(&b.bsp, &result, &AmbientOptions::none());
        assert!(none[1..=result.num_leaves()].iter().all(|a| *a == [0; 4]));
        let no_sky = ambient_levels_with(
            &b.bsp,
            &result,
            &AmbientOptions { off: [false, true, false, false], ..Default::default() },
        );
        assert!(no_sky.iter().all(|a| a[1] == 0));
    }

    #[test]
    fn a_side_file_from_another_compile_is_ignored_and_a_broken_one_is_an_error() {
        let Some((bsp_path, _)) = copy_shared(NOAMBIENT_MAP, "side", false) else { return };
        let side = bsp_path.with_extension("texinfo.json");
        let input = VisInput::read(&bsp_path).expect("reads without a side file");
        assert!(input.bsp.as_ref().expect("bsp").texinfo_json.is_none());

        std::fs::write(&side, r#"{"4": {"noambient": true}, "100000": {}}"#).expect("write");
        let input = VisInput::read(&bsp_path).expect("reads");
        let read = input.bsp.as_ref().and_then(|b| b.texinfo_json.as_ref()).expect("side file");
        assert!(!read.matches, "texinfo 100000 is not in this BSP");
        assert!(input.ambient_options([false; 4]).silent_texinfo.is_empty(), "ignored, as ericw-tools does");

        std::fs::write(&side, "{\"4\": {\"noambient\": \"yes\"}}").expect("write");
        let err = VisInput::read(&bsp_path).expect_err("a broken side file");
        assert!(matches!(err, VisdataError::TexinfoJson(_)));
        assert!(err.to_string().contains("m.texinfo.json"), "{err}");
    }

    #[test]
    fn cluster_boxes_hold_leaf_bounds_and_portals_and_unknown_leaves_are_unbounded() {
        let Some((bsp_path, _)) = copy_shared("ericw/dm1.bsp", "boxes", false) else { return };
        let mut input = VisInput::read(&bsp_path).expect("dm1");
        let b = &input.bsp.as_ref().expect("bsp").bsp;
        let boxes = cluster_boxes(b, &input.prt);
        assert_eq!(boxes.len(), input.prt.num_clusters as usize);
        for (j, &c) in input.prt.leaf_clusters.iter().enumerate() {
            let l = &b.leaves[j + 1];
            let (mins, maxs) = (DVec3::from(l.mins.map(f64::from)), DVec3::from(l.maxs.map(f64::from)));
            let bx = &boxes[c as usize];
            assert!(
                bx.contains_point(mins - LEAF_BOUNDS_SLACK, 0.0)
                    && bx.contains_point(maxs + LEAF_BOUNDS_SLACK, 0.0)
            );
        }
        for p in &input.prt.portals {
            for &c in &p.leaves {
                assert!(p.winding.points.iter().all(|&q| boxes[c as usize].contains_point(q, 0.0)));
            }
        }
        // A leaf the BSP lacks (or with NaN bounds) makes its cluster's box unbounded.
        let bsp = &mut input.bsp.as_mut().expect("bsp").bsp;
        bsp.leaves[1].mins[0] = f32::NAN;
        let c = input.prt.leaf_clusters[0] as usize;
        let boxes = cluster_boxes(bsp, &input.prt);
        assert!(!boxes[c].mins.is_finite() && boxes[c].maxs.x == f64::INFINITY);
        bsp.leaves.truncate(1);
        assert!(cluster_boxes(bsp, &input.prt).iter().all(|bx| bx.mins.x == f64::NEG_INFINITY));
        // Inverted (cleared) stored bounds are unknown bounds too.
        let bsp = &mut input.bsp.as_mut().expect("bsp").bsp;
        *bsp = VisInput::read(&bsp_path).expect("dm1").bsp.expect("bsp").bsp;
        bsp.leaves[1].mins = [1.0; 3];
        bsp.leaves[1].maxs = [-1.0; 3];
        assert_eq!(cluster_boxes(bsp, &input.prt)[c].maxs.x, f64::INFINITY);
    }

    #[test]
    fn level_cluster_boxes_union_the_leaves_of_each_cluster_and_leave_unnamed_ones_unbounded() {
        use sightline_formats::bsp::q2;
        let Some(dir) = sightline_tests::shared_maps() else { return };
        let (bsp_path, prt_path) = (dir.join("q2/dm2.bsp"), dir.join("q2/dm2.prt"));
        let (Ok(bytes), Ok(prt_bytes)) = (std::fs::read(&bsp_path), std::fs::read(&prt_path)) else { return };
        let file = q2::read(&bytes).expect("dm2");
        let mut level = q2::to_level(&file);
        let prt = sightline_formats::prt::read_bytes(&prt_bytes, "dm2.prt").expect("dm2.prt");
        let boxes = level_cluster_boxes(&level, &prt);
        assert_eq!(boxes.len(), prt.num_clusters as usize);
        for l in level.leaves.iter().filter(|l| l.cluster >= 0) {
            let bx = &boxes[l.cluster as usize];
            let (mins, maxs) = (DVec3::from(l.mins.map(f64::from)), DVec3::from(l.maxs.map(f64::from)));
            assert!(bx.contains_point(mins, 0.0) && bx.contains_point(maxs, 0.0));
            assert!(bx.mins.is_finite() && bx.maxs.is_finite(), "dm2 stores sound bounds");
        }
        // A cluster no leaf names, or one of whose leaves has inverted bounds, is unbounded.
        let c = level.leaves.iter().position(|l| l.cluster >= 0).expect("an open leaf");
        let cluster = level.leaves[c].cluster as usize;
        level.leaves[c].mins = [1.0; 3];
        level.leaves[c].maxs = [-1.0; 3];
        assert_eq!(level_cluster_boxes(&level, &prt)[cluster].maxs.x, f64::INFINITY);
        level.leaves.iter_mut().filter(|l| l.cluster == cluster as i32).for_each(|l| l.cluster = -1);
        let boxes = level_cluster_boxes(&level, &prt);
        assert_eq!((boxes[cluster].mins.x, boxes[cluster].maxs.x), (f64::NEG_INFINITY, f64::INFINITY));
    }
}
