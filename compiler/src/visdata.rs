//! A [`VisResult`] stored the way files hold a PVS: per cluster in a [`Level`] ([`store_pvs`]),
//! per vis leaf in a Quake `.bsp` ([`write_into_bsp`]) or a `.vis` file ([`Rows::vis_file`]); and
//! the input of vis on a Quake map, a `.bsp` with the `.prt` beside it ([`VisInput`]).
//!
//! # Conventions
//! - Rows are uncompressed in Quake's byte layout ([`sightline_formats::bits::bytes`]) and
//!   compressed with [`sightline_formats::rle`].
//! - Drop-in rules for a `.bsp` (as the reference vis): vis leaf `j` of the portal file is BSP
//!   leaf `j + 1` and owns PVS row `j`; leaves of one cluster share one compressed row, and
//!   identical rows are stored once, at the offset of their first occurrence in leaf order. Every
//!   vis leaf's ambient sound levels (water, sky, slime, lava) become 255 when its PVS holds a
//!   face whose texture makes that sound ([`sightline_formats::texture`]), else 0. Leaves that
//!   are not vis leaves keep their `visofs` and ambient levels.
//! - A level stores one row per cluster, in cluster order, without sharing.

use std::collections::HashMap;
use std::io;
use std::path::{Path, PathBuf};

use sightline_formats::Level;
use sightline_formats::bits;
use sightline_formats::bsp::{self, Bsp, BspError};
use sightline_formats::prt::{self, PortalFile, PrtError};
use sightline_formats::rle;
use sightline_formats::texture::TextureKind;
use sightline_formats::visfile::{self, VisFileError};
use thiserror::Error;

use crate::vis::VisResult;

/// Why vis input could not be read or its rows not be stored.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum VisdataError {
    /// A file could not be read.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The `.bsp` does not parse.
    #[error("{}: invalid BSP", path.display())]
    Bsp {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: BspError,
    },
    /// The `.prt` beside a `.bsp` is missing.
    #[error(
        "{} not found: vis needs the portal file your BSP compiler writes beside the .bsp (none is written when the map leaks)",
        path.display()
    )]
    PrtMissing {
        /// Where it was looked for.
        path: PathBuf,
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
    /// The `.bsp` could not take the new visdata (for example more than 2 GiB of it).
    #[error(transparent)]
    BspWrite(BspError),
    /// The rows do not fit a `.vis` file.
    #[error(transparent)]
    VisFile(#[from] VisFileError),
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
}

/// What vis reads: a portal file, and the `.bsp` it belongs to when vis writes into one.
#[derive(Debug, Clone)]
pub struct VisInput {
    /// The portal file: the `.bsp`'s sibling with the extension `.prt`, or the input itself.
    pub prt_path: PathBuf,
    /// Its content.
    pub prt: PortalFile,
    /// The `.bsp`, when the input is one.
    pub bsp: Option<BspInput>,
}

impl VisInput {
    /// Reads `path`: a `.bsp` (by extension, any case) and the `.prt` beside it, which must have
    /// as many vis leaves; or a portal file alone.
    pub fn read(path: &Path) -> Result<Self, VisdataError> {
        let is_bsp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp"));
        let bsp = if is_bsp {
            let bytes =
                std::fs::read(path).map_err(|source| VisdataError::Read { path: path.into(), source })?;
            let bsp = bsp::read(&bytes).map_err(|source| VisdataError::Bsp { path: path.into(), source })?;
            Some(BspInput { path: path.into(), bytes, bsp })
        } else {
            None
        };
        let prt_path = if is_bsp { path.with_extension("prt") } else { path.to_path_buf() };
        let text = match std::fs::read_to_string(&prt_path) {
            Ok(t) => t,
            Err(e) if is_bsp && e.kind() == io::ErrorKind::NotFound => {
                return Err(VisdataError::PrtMissing { path: prt_path });
            }
            Err(source) => return Err(VisdataError::Read { path: prt_path, source }),
        };
        let prt = prt::read(&text, &prt_path.display().to_string())?;
        if let Some(b) = &bsp
            && b.bsp.visleafs() != prt.num_leaves as usize
        {
            return Err(VisdataError::Mismatch {
                bsp: b.path.clone(),
                bsp_leaves: b.bsp.visleafs(),
                prt: prt_path,
                prt_leaves: prt.num_leaves,
            });
        }
        Ok(Self { prt_path, prt, bsp })
    }
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
    /// Compress the rows of `result` (leaves of a cluster share one row).
    pub fn new(result: &VisResult) -> Self {
        let mut data = Vec::new();
        let mut seen: HashMap<Vec<u8>, u32> = HashMap::new();
        let mut cluster_offset: Vec<Option<u32>> = vec![None; result.num_clusters()];
        let mut leaf_offsets = Vec::with_capacity(result.num_leaves());
        let mut row = Vec::new();
        let mut packed = Vec::new();
        for (leaf, &c) in result.leaf_clusters().iter().enumerate() {
            let slot = &mut cluster_offset[c as usize];
            let ofs = match *slot {
                Some(o) => o,
                None => {
                    result.leaf_row_bytes(leaf, &mut row);
                    packed.clear();
                    rle::encode_row(&row, &mut packed);
                    let o = *seen.entry(packed.clone()).or_insert_with(|| {
                        let o = data.len() as u32;
                        data.extend_from_slice(&packed);
                        o
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
/// visible leaf makes, else 0), other leaves unchanged.
pub fn ambient_levels(bsp: &Bsp, result: &VisResult) -> Vec<[u8; 4]> {
    // Sounds present in each vis leaf's own faces.
    let own: Vec<[bool; 4]> = (0..result.num_leaves())
        .map(|j| {
            let mut s = [false; 4];
            if let Some(leaf) = bsp.leaves.get(j + 1) {
                let first = leaf.first_marksurface as usize;
                let marks =
                    bsp.marksurfaces.get(first..first + leaf.num_marksurfaces as usize).unwrap_or_default();
                for &m in marks {
                    let sound = bsp
                        .faces
                        .get(m as usize)
                        .and_then(|f| TextureKind::of(bsp.face_texture_name(f)).ambient());
                    if let Some(sound) = sound {
                        s[sound.index()] = true;
                    }
                }
            }
            s
        })
        .collect();
    let mut out: Vec<[u8; 4]> = bsp.leaves.iter().map(|l| l.ambient).collect();
    let mut row = Vec::new();
    for j in 0..result.num_leaves() {
        result.leaf_row_bytes(j, &mut row);
        let mut s = [false; 4];
        for (k, sounds) in own.iter().enumerate() {
            if bits::bytes::get(&row, k) {
                for (a, b) in s.iter_mut().zip(sounds) {
                    *a |= *b;
                }
            }
        }
        if let Some(slot) = out.get_mut(j + 1) {
            *slot = s.map(|on| if on { 255 } else { 0 });
        }
    }
    out
}

/// The `.bsp` bytes `original` (parsed as `bsp`) with the visdata of `rows`, every vis leaf's
/// `visofs` pointing at its row ([`bsp::write_vis_rows`]), and ambient levels from
/// [`ambient_levels`].
pub fn write_into_bsp(
    original: &[u8],
    bsp: &Bsp,
    result: &VisResult,
    rows: &Rows,
) -> Result<Vec<u8>, VisdataError> {
    let ambient = ambient_levels(bsp, result);
    bsp::write_vis_rows(original, bsp, &rows.data, &rows.leaf_offsets, Some(&ambient))
        .map_err(VisdataError::BspWrite)
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
        vis::run(&prt, &VisOptions::default(), &|_| {}).expect("vis")
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
}
