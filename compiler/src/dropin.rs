//! The drop-in vis: any compiled map of the Quake family, its portals given (the `.prt` its
//! compiler wrote) or rebuilt from its tree, to a PVS (with the PHS, ambient levels and far plane
//! as the game has them) written back into the `.bsp`, into an external `.vis` file, or, for a
//! portal file alone, into `NAME.vis`. One route for every game, as the reference vis tools run:
//! an editor plugin or a build farm calls [`run`] (or [`pack()`] for a folder) and gets the file
//! written atomically and a [`Report`].
//!
//! | input | portals | written | module |
//! |---|---|---|---|
//! | Quake BSP29/BSP2/BSP2-RMQ, Half-Life BSP30 | `.prt` beside it, or its tree | visdata and ambient levels into the `.bsp`, or an external `.vis` | [`quake`] |
//! | a `.prt` alone | the file | `NAME.vis` ([`sightline_formats::visfile`]) | [`quake`] |
//! | Quake 2 `IBSP` 38 | qbsp's PRT1 over clusters | PVS and PHS lump (or the PHS alone) | [`quake2`] |
//! | Quake 3 `IBSP` 46/47 | q3map2's portal file | uncompressed cluster rows | [`quake3`] |
//!
//! The game is found once from the file's first bytes ([`sightline_formats::bsp::Game::sniff`]).
//! Options a game cannot use are refused before any work, naming the file.

pub mod folder;
pub mod quake;
pub mod quake2;
pub mod quake3;
mod report;

use std::io;
use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_formats::bsp::{BspError, Game};
use sightline_job::atomic::{Durability, write_file_with};
use sightline_job::input::{InputError, read_input};
use sightline_job::progress::Progress;
use thiserror::Error;

use crate::bsp_portals::BspPortalOptions;
use crate::vis::{VisError, VisOptions};
use crate::visdata::VisdataError;

pub use report::{PackReport, PackedMap, Q2Report, Q3Report, QuakeReport, Report, SkippedMap};

/// How to vis a compiled map. `Default` is Quake's full vis with every sound on, portals read from
/// beside the `.bsp`, written back into it.
#[derive(Debug, Clone, Default)]
pub struct DropInOptions {
    /// The flow's options (level, threads, state file, limits, cancel flag).
    pub vis: VisOptions,
    /// Clusters whose boxes are farther apart than this many units stop seeing each other
    /// (`None` or 0: off). Quake 1, Half-Life and Quake 2.
    pub farplane: Option<f64>,
    /// Ambient sounds switched off, indexed by [`sightline_formats::texture::Ambient::index`].
    pub ambient_off: [bool; 4],
    /// Quake 2 only: recompute the PHS from the PVS in the file, keeping every PVS byte.
    pub phs_only: bool,
    /// Rebuild the portals from the `.bsp`'s tree instead of reading the `.prt` beside it (Quake 1
    /// and Half-Life).
    pub portals_from_tree: Option<BspPortalOptions>,
    /// Start afresh: delete the state file ([`VisOptions::state`]) before vis instead of resuming
    /// from it.
    pub restart: bool,
    /// Write the PVS as an external `.vis` record into this file and leave the `.bsp` unchanged
    /// (BSP29 only, as engines load them).
    pub external_vis: Option<PathBuf>,
}

impl DropInOptions {
    /// The far plane distance when one is on.
    pub fn farplane(&self) -> Option<f64> {
        self.farplane.filter(|&d| d > 0.0)
    }
}

/// Why the drop-in vis did not write its output. Every error names the file it is about.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DropInError {
    /// An option this input cannot use, or a file that cannot serve (the text says which).
    #[error("{}: {why}", path.display())]
    Refused {
        /// The input.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// A file or folder could not be read ([`sightline_job::input::read_input`]: a regular file
    /// only; the error names it).
    #[error(transparent)]
    Read(#[from] InputError),
    /// A compiled map is malformed or cannot take the visibility.
    #[error("{}", path.display())]
    Bsp {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: BspError,
    },
    /// Reading the vis input or laying out its rows failed (the error names the file).
    #[error(transparent)]
    Visdata(Box<VisdataError>),
    /// The rows could not be laid out for the file (for example an external `.vis` record).
    #[error("{}", path.display())]
    At {
        /// The file.
        path: PathBuf,
        /// What failed.
        #[source]
        source: Box<VisdataError>,
    },
    /// An output would replace one of the run's inputs (the `.bsp`, the portal file) or another
    /// output; refused before any work.
    #[error(transparent)]
    NotApart(#[from] sightline_job::apart::CheckError),
    /// The portal file does not parse (the error names the file).
    #[error(transparent)]
    Prt(#[from] sightline_formats::prt::PrtError),
    /// Vis itself failed or was stopped ([`VisError::Interrupted`]).
    #[error("{}", path.display())]
    Vis {
        /// The input.
        path: PathBuf,
        /// What happened.
        #[source]
        source: VisError,
    },
    /// The output could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
}

impl From<VisdataError> for DropInError {
    fn from(e: VisdataError) -> Self {
        Self::Visdata(Box::new(e))
    }
}

impl DropInError {
    /// The vis error behind this one, if vis itself stopped it (for example
    /// [`VisError::Interrupted`]).
    pub fn vis(&self) -> Option<&VisError> {
        match self {
            Self::Vis { source, .. } => Some(source),
            _ => None,
        }
    }

    pub(crate) fn refused(path: &Path, why: impl Into<String>) -> Self {
        Self::Refused { path: path.into(), why: why.into() }
    }

    pub(crate) fn bsp(path: &Path) -> impl FnOnce(BspError) -> Self + '_ {
        move |source| Self::Bsp { path: path.into(), source }
    }

    pub(crate) fn vis_at(path: &Path) -> impl FnOnce(VisError) -> Self + '_ {
        move |source| Self::Vis { path: path.into(), source }
    }
}

/// Vis of the compiled map or portal file at `path` (see the module docs), written atomically;
/// `started` is when the caller's work began (reports count from it, and the output is flushed to
/// disk when the work took long enough to matter). `progress` gets vis's phases and notes, and
/// warnings about the input; [`VisOptions::cancel`] stops the run (with the state saved when
/// there is a state file).
pub fn run(
    path: &Path,
    opts: &DropInOptions,
    progress: &dyn Progress,
    started: Instant,
) -> Result<Report, DropInError> {
    // Read once: the game is told by the first bytes of what the run then parses.
    let bytes = read_input(path)?;
    check_outputs(path, opts)?;
    match Game::sniff(&bytes) {
        Some(Game::Quake3) => quake3::run(path, bytes, opts, progress, started).map(Report::Quake3),
        Some(Game::Quake2) => quake2::run(path, bytes, opts, progress, started).map(Report::Quake2),
        _ => quake::run(path, bytes, opts, progress, started).map(Report::Quake),
    }
}

/// The portal file a vis of the input at `path` reads, found as [`run`] finds it for the file's
/// game (the `.prt` beside a `.bsp`, its tree with [`DropInOptions::portals_from_tree`], or the
/// portal file itself): what the shards of a plan flow ([`crate::vis::shard`]), whose merge is
/// then written by [`run`] with [`VisOptions::merge`].
pub fn portals(path: &Path, opts: &DropInOptions) -> Result<sightline_formats::prt::PortalFile, DropInError> {
    let bytes = read_input(path)?;
    match Game::sniff(&bytes) {
        Some(Game::Quake3) => Ok(portals_beside(path, quake3::PORTALS_HINT)?.1),
        Some(Game::Quake2) => Ok(portals_beside(path, "")?.1),
        _ => Ok(quake::vis_input(path, bytes, opts)?.0.prt),
    }
}

/// Refuses, before any work, the files the run at `path` would write (an external `.vis`, the
/// `NAME.vis` of a portal file, the checkpoint) when one would replace an input (the compiled map
/// or portal file, the portal file and `NAME.texinfo.json` beside a `.bsp`) or another of them,
/// or cannot be written where it points ([`sightline_job::apart::check_outputs`]). A `.bsp`
/// written back in place is rewritten on purpose: it counts as an input, checked writable only.
fn check_outputs(path: &Path, opts: &DropInOptions) -> Result<(), DropInError> {
    let written = match &opts.external_vis {
        Some(out) => Some(out.clone()),
        None => (!quake::is_bsp(path)).then(|| path.with_extension("vis")),
    };
    if written.is_none() {
        sightline_job::atomic::check_writable(path)
            .map_err(|source| DropInError::Write { path: path.into(), source })?;
    }
    let inputs = inputs_of(path);
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    let outputs: Vec<&Path> = written.iter().chain(&opts.vis.state).map(PathBuf::as_path).collect();
    Ok(sightline_job::apart::check_outputs(&inputs, &outputs)?)
}

/// The files a vis of `path` may read: the file, and for a `.bsp` the portal files and the
/// `NAME.texinfo.json` beside it.
pub(crate) fn inputs_of(path: &Path) -> Vec<PathBuf> {
    let mut inputs = vec![path.to_path_buf()];
    if quake::is_bsp(path) {
        inputs.extend(sightline_formats::prt::beside_bsp(path));
        inputs.push(sightline_formats::texinfo_json::path_beside(path));
    }
    inputs
}

/// Vis of every `.bsp` in the folder `dir` into one external `.vis` pack at `out` (see [`folder`]).
pub use folder::run as pack;

/// The portal file beside the compiled map at `path` ([`sightline_formats::prt::beside_bsp`]),
/// read; `hint` ends the error when there is none (how the game's compiler writes one).
pub(crate) fn portals_beside(
    path: &Path,
    hint: &str,
) -> Result<(PathBuf, sightline_formats::prt::PortalFile), DropInError> {
    let tried = sightline_formats::prt::beside_bsp(path);
    // The first that exists: one that is not a regular file is refused by name, not passed over.
    let Some(prt_path) = tried.iter().find(|p| p.exists()) else {
        return Err(DropInError::refused(
            path,
            format!(
                "no portal file beside it (tried {tried:?}{hint}); or rebuild the portals from the BSP's own tree with `sightline vis --portals-from-bsp {}`",
                path.display()
            ),
        ));
    };
    let bytes = read_input(prt_path)?;
    let prt = sightline_formats::prt::read_bytes(&bytes, &prt_path.display().to_string())?;
    Ok((prt_path.clone(), prt))
}

/// Writes `bytes` to `path` atomically, with the durability of work started at `started`.
pub(crate) fn write(path: &Path, bytes: &[u8], started: Instant) -> Result<(), DropInError> {
    write_file_with(path, bytes, Durability::for_work(started.elapsed()))
        .map_err(|source| DropInError::Write { path: path.into(), source })
}

/// Runs vis on `prt` for the input at `path` (after deleting the state file when
/// [`DropInOptions::restart`]): errors name it.
pub(crate) fn flow(
    prt: &sightline_formats::prt::PortalFile,
    opts: &DropInOptions,
    progress: &dyn Progress,
    path: &Path,
) -> Result<crate::vis::VisResult, DropInError> {
    if opts.restart
        && let Some(state) = &opts.vis.state
    {
        match std::fs::remove_file(state) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(DropInError::refused(state, format!("cannot delete it (--no-state): {e}"))),
        }
    }
    crate::vis::run(prt, &opts.vis, progress).map_err(DropInError::vis_at(path))
}

/// [`flow`] with the clusters merged as `merge` says (a `func_viscluster` of the `.bsp`): vis
/// runs on the merged portal file (`vis::coarsen`'s, whose conservativeness argument holds), and
/// the result is expanded back to the input's clusters. A note says what each entity merged, in
/// `unit`s (what a portal-file leaf is: "vis leaves", or "clusters" for Quake 2 and 3).
pub(crate) fn flow_merged(
    prt: &sightline_formats::prt::PortalFile,
    merge: Option<&crate::viscluster::BspMerge>,
    unit: &str,
    opts: &DropInOptions,
    progress: &dyn Progress,
    path: &Path,
) -> Result<crate::vis::VisResult, DropInError> {
    let Some(m) = merge else { return flow(prt, opts, progress, path) };
    for (i, n) in m.leaves.iter().enumerate() {
        progress.note(&format!(
            "{}: func_viscluster {} (by entity order) merged {n} {unit}",
            path.display(),
            i + 1
        ));
    }
    let coarse = crate::vis::coarsen::build(prt, &m.new_id, m.groups);
    let result = flow(&coarse, opts, progress, path)?;
    Ok(crate::vis::coarsen::expand(result, prt, &m.new_id))
}

/// Every cluster's row of `result` in Quake's byte layout, back to back (Quake 2 and 3 rows).
pub(crate) fn cluster_rows(result: &crate::vis::VisResult, clusters: usize) -> Vec<u8> {
    let mut rows = Vec::with_capacity(clusters * sightline_formats::bits::bytes::len(clusters));
    let mut row = Vec::new();
    for c in 0..clusters {
        result.leaf_row_bytes(c, &mut row);
        rows.extend_from_slice(&row);
    }
    rows
}
