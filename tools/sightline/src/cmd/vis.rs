//! `sightline vis`: the PVS of a Quake `.bsp` (from its sibling `.prt`, written back into the
//! `.bsp` atomically) or of a `.prt` (written to `<name>.vis`).
//!
//! A Quake 2 `.bsp` (`IBSP` 38) takes its own path: qbsp's PRT1 beside it names clusters, so vis
//! computes cluster rows, [`sightline_compiler::phs`] adds the PHS, and the visibility lump is
//! replaced ([`sightline_formats::bsp::q2`]). `--phs-only` recomputes only the PHS of a vised
//! file, keeping every PVS byte. The far plane culls by cluster boxes made from the file's
//! leaves ([`visdata::level_cluster_boxes`]) before the PHS is formed; ambient options do not
//! apply there. A Quake 3
//! `.bsp` (`IBSP` 46/47) goes to [`super::vis_q3`].
//!
//! The library does the work: [`sightline_compiler::visdata`] reads the input, lays out the rows
//! and writes them into the `.bsp` (its module docs give the drop-in rules), and
//! [`sightline_formats::visfile`] is the `.vis` file. This module parses the arguments, handles
//! Ctrl-C, draws progress and prints the report.
//!
//! # The ericw-tools / id command line
//! `sightline vis` also takes the command line of ericw-tools' and id's `vis`, as TrenchBroom
//! compile profiles and build scripts pass it: a base name (`e1m1` reads `e1m1.bsp` when `e1m1`
//! is not a file, see [`resolve_input`]) and single-dash options anywhere on the line. Before clap
//! parses, [`ericw_args`] turns each one into the `--` flag it means ([`ERICW_OPTIONS`]), drops
//! those that only steer the reference tool's logging, and rejects any other single-dash word.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use anyhow::{Context, bail};

use sightline_compiler::phs;
use sightline_compiler::vis::{self, VisOptions, VisPhase, VisProgress, VisResult, VisStats};
use sightline_compiler::visdata::{self, Rows};
use sightline_formats::bsp::q2;
use sightline_formats::prt::{PortalFile, PrtFormat};
use sightline_formats::texture::Ambient;

use crate::cli::Outcome;
use crate::cmd::vis_external;

/// What `sightline vis` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Compute visibility for a Quake `.bsp` (reading its `.prt`) or a `.prt` file";

/// Arguments of `sightline vis`. `Default` (for callers building them in code) is every flag off,
/// no input and `threads` 0 (chosen from the work, see `--threads`).
#[derive(Debug, Default, clap::Args)]
#[command(about = ABOUT)]
#[command(after_help = "ericw-tools / id vis command lines work too: `sightline vis -threads 4 -fast e1m1` \
reads e1m1.bsp; single-dash options (-threads N, -fast, -level N, -noambient, -noambientsky, \
-noambientwater, -noambientslime, -noambientlava, -visdist N / -farplane N, -nostate, -noprogress) \
may come before or after the file, and -v, -verbose, -nolog, -nopercent, -nostat and other \
logging options are accepted and ignored.")]
pub struct Args {
    /// A Quake, Half-Life or Quake 2 `.bsp` (its `.prt` must sit beside it), a base name (`e1m1`
    /// for `e1m1.bsp`), or a `.prt` file.
    pub input: PathBuf,
    /// Worker threads (0: every core, or one for a map small enough to take milliseconds). The
    /// result is the same for any count.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Vis options.
    #[command(flatten)]
    pub vis: VisFlags,
    /// Far plane: after vis, clusters whose bounding boxes are more than this many units apart
    /// stop seeing each other (nothing within the distance is hidden); 0 turns it off. Needs a
    /// `.bsp` (for its leaf bounds).
    #[arg(
        long,
        visible_alias = "visdist",
        value_name = "UNITS",
        value_parser = parse_distance,
        allow_negative_numbers = true
    )]
    pub farplane: Option<f64>,
    /// Write every ambient sound level as 0.
    #[arg(long)]
    pub no_ambient: bool,
    /// No ambient sky sound.
    #[arg(long)]
    pub no_ambient_sky: bool,
    /// No ambient water sound.
    #[arg(long)]
    pub no_ambient_water: bool,
    /// No ambient slime sound.
    #[arg(long)]
    pub no_ambient_slime: bool,
    /// No ambient lava sound.
    #[arg(long)]
    pub no_ambient_lava: bool,
    /// Start afresh: delete the `--state` file first instead of resuming from it.
    #[arg(long)]
    pub no_state: bool,
    /// Draw no progress bars.
    #[arg(long)]
    pub no_progress: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Quake 2 `.bsp` only: recompute the PHS from the PVS already in the file and rewrite it,
    /// changing no byte of the PVS rows (repairs the PHS ericw-tools 2.0.0-alpha11 writes).
    #[arg(long)]
    pub phs_only: bool,
    /// Rebuild the portals from the `.bsp`'s own tree instead of reading a `.prt` (one beside it
    /// is ignored): re-vis a compiled map without its source.
    #[arg(long)]
    pub portals_from_bsp: bool,
    /// With --portals-from-bsp: whether water, slime and lava let sight through [default:
    /// transparent].
    #[arg(long, value_enum)]
    pub water: Option<crate::cmd::portals::Water>,
    /// With --portals-from-bsp: give every leaf its own cluster, even where the file's own PVS
    /// gives all open leaves under a node one row (qbsp's detail clusters): tighter, slower.
    #[arg(long)]
    pub no_clusters: bool,
    /// Write the PVS into an external `.vis` file (as Quakespasm, vkQuake, QSS and Mark V load
    /// beside a BSP29 map) and leave the `.bsp` as it is. Given a folder, one pack of every `.bsp`
    /// in it (needs -o).
    #[arg(long)]
    pub external_vis: bool,
    /// With --external-vis: the file to write (default: the `.bsp`'s name with `.vis`).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

impl Args {
    /// The ambient sounds switched off, indexed by [`Ambient::index`].
    pub fn ambient_off(&self) -> [bool; 4] {
        let mut off = [self.no_ambient; 4];
        for (sound, flag) in [
            (Ambient::Water, self.no_ambient_water),
            (Ambient::Sky, self.no_ambient_sky),
            (Ambient::Slime, self.no_ambient_slime),
            (Ambient::Lava, self.no_ambient_lava),
        ] {
            off[sound.index()] |= flag;
        }
        off
    }
}

/// A far-plane distance: a number >= 0 (0 is off).
fn parse_distance(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(d) if d.is_finite() && d >= 0.0 => Ok(d),
        _ => Err(format!("`{s}` is not a distance (a number of units >= 0)")),
    }
}

/// What one option of ericw-tools' or id's `vis` becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EricwOption {
    /// A Sightline flag without a value.
    Flag(&'static str),
    /// A Sightline flag that takes the next word as its value.
    Value(&'static str),
    /// Accepted and ignored (logging and other reference-tool settings that change no output).
    Ignored,
    /// Accepted and ignored with the next word (its value).
    IgnoredWithValue,
    /// Accepted and ignored, and so is the next word when it is a number (`-lowpriority [0]`).
    IgnoredOptionalNumber,
}

/// The single-dash options `sightline vis` takes (names as ericw-tools spells them; matched
/// without regard to case), and what each becomes.
pub const ERICW_OPTIONS: &[(&str, EricwOption)] = &[
    ("threads", EricwOption::Value("--threads")),
    ("fast", EricwOption::Flag("--fast")),
    ("level", EricwOption::Value("--level")),
    ("visdist", EricwOption::Value("--farplane")),
    ("farplane", EricwOption::Value("--farplane")),
    ("noambient", EricwOption::Flag("--no-ambient")),
    ("noambientsky", EricwOption::Flag("--no-ambient-sky")),
    ("noambientwater", EricwOption::Flag("--no-ambient-water")),
    ("noambientslime", EricwOption::Flag("--no-ambient-slime")),
    ("noambientlava", EricwOption::Flag("--no-ambient-lava")),
    ("nostate", EricwOption::Flag("--no-state")),
    ("noprogress", EricwOption::Flag("--no-progress")),
    ("help", EricwOption::Flag("--help")),
    // ericw-tools: "-quiet / -noverbose: -nopercent -nostat -noprogress".
    ("quiet", EricwOption::Flag("--no-progress")),
    ("noverbose", EricwOption::Flag("--no-progress")),
    ("nopercent", EricwOption::Ignored),
    ("nostat", EricwOption::Ignored),
    ("v", EricwOption::Ignored),
    ("vv", EricwOption::Ignored),
    ("verbose", EricwOption::Ignored),
    ("log", EricwOption::Ignored),
    ("nolog", EricwOption::Ignored),
    ("nocolor", EricwOption::Ignored),
    ("autoclean", EricwOption::Ignored),
    ("noautoclean", EricwOption::Ignored),
    ("defaultpaths", EricwOption::Ignored),
    ("nodefaultpaths", EricwOption::Ignored),
    ("lowpriority", EricwOption::IgnoredOptionalNumber),
    // Game and search paths: ericw-tools' vis reads no texture through them for Quake maps.
    ("gamedir", EricwOption::IgnoredWithValue),
    ("basedir", EricwOption::IgnoredWithValue),
    ("path", EricwOption::IgnoredWithValue),
    ("filepriority", EricwOption::IgnoredWithValue),
];

/// The arguments after `vis` with ericw-tools / id single-dash options turned into Sightline's
/// (see [`ERICW_OPTIONS`]). Everything else passes through unchanged: `--` flags (with the next
/// word when `long_takes_value` says the flag takes one and it is not given as `--flag=value`),
/// the short flags in `shorts` (clap's, such as `-h`), numbers, and every word after `--`.
/// Errors name an unknown single-dash word, or an option missing its value.
pub fn ericw_args(
    words: &[OsString],
    long_takes_value: &dyn Fn(&str) -> bool,
    shorts: &[char],
) -> Result<Vec<OsString>, String> {
    let mut out = Vec::with_capacity(words.len());
    let mut i = 0;
    while i < words.len() {
        let word = &words[i];
        i += 1;
        let Some(s) = word.to_str() else {
            out.push(word.clone());
            continue;
        };
        if s == "--" {
            out.extend(words[i - 1..].iter().cloned());
            break;
        }
        if let Some(long) = s.strip_prefix("--") {
            out.push(word.clone());
            if !long.contains('=') && long_takes_value(long) && i < words.len() {
                out.push(words[i].clone());
                i += 1;
            }
            continue;
        }
        let Some(name) = single_dash_name(s) else {
            out.push(word.clone());
            continue;
        };
        let mut chars = name.chars();
        if let (Some(c), None) = (chars.next(), chars.next())
            && shorts.contains(&c)
        {
            out.push(word.clone());
            continue;
        }
        let lower = name.to_ascii_lowercase();
        let Some(&(_, option)) = ERICW_OPTIONS.iter().find(|(n, _)| *n == lower) else {
            return Err(format!(
                "unknown vis option `{s}` (ericw-tools options such as -threads N, -fast, -level N, \
                 -noambient, -visdist N are taken; see `sightline vis --help`)"
            ));
        };
        let next = words.get(i);
        match option {
            EricwOption::Flag(long) => out.push(long.into()),
            EricwOption::Value(long) => {
                let Some(value) = next else { return Err(format!("vis option `{s}` needs a value")) };
                out.push(long.into());
                out.push(value.clone());
                i += 1;
            }
            EricwOption::Ignored => {}
            EricwOption::IgnoredWithValue => {
                if next.is_none() {
                    return Err(format!("vis option `{s}` needs a value"));
                }
                i += 1;
            }
            EricwOption::IgnoredOptionalNumber => {
                if next.and_then(|v| v.to_str()).is_some_and(|v| v.parse::<i64>().is_ok()) {
                    i += 1;
                }
            }
        }
    }
    Ok(out)
}

/// The name of a single-dash option word (`-threads` gives `threads`): a word after one `-` that
/// is not a number. `--` words are not (see [`ericw_args`]).
pub fn single_dash_name(word: &str) -> Option<&str> {
    word.strip_prefix('-').filter(|n| !n.is_empty() && !n.starts_with('-') && word.parse::<f64>().is_err())
}

/// The file a `vis` input names: `NAME.bsp` for a base name `NAME` (not a file itself, not
/// ending in `.bsp` or `.prt`, and `NAME.bsp` is a file; `e1m1` or `e1m1.final`), else the input
/// itself.
pub fn resolve_input(input: &Path) -> PathBuf {
    let named =
        input.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp") || e.eq_ignore_ascii_case("prt"));
    if !named && !input.is_file() {
        let mut bsp = input.as_os_str().to_owned();
        bsp.push(".bsp");
        let bsp = PathBuf::from(bsp);
        if bsp.is_file() {
            return bsp;
        }
    }
    input.to_path_buf()
}

/// The vis flags that `sightline vis` and `sightline compile` share.
#[derive(Debug, Clone, clap::Args)]
pub struct VisFlags {
    /// Base vis only (like the reference `-fast`): fast and loose.
    #[arg(long)]
    pub fast: bool,
    /// Separator tests, 0..=4 as the reference `vis -level` defines them (4 is the tightest).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=4))]
    pub level: u8,
    /// Checkpoint file: resumed from when present, written every `--checkpoint-secs` and on
    /// Ctrl-C. The same command run again resumes from it.
    #[arg(long)]
    pub state: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, default_value_t = 180)]
    pub checkpoint_secs: u64,
    /// Stop after this many flow portals (after writing the state): for testing resumes.
    #[arg(long, hide = true)]
    pub stop_after: Option<usize>,
    /// Refuse a vis whose estimated memory is above this size (bytes, or with K, M, G, T: 512M,
    /// 8G); the memory the machine has available is always a limit too.
    #[arg(long, value_name = "SIZE", value_parser = sightline_compiler::memory::parse_size)]
    pub max_memory: Option<u64>,
    /// Refuse a vis whose estimated work is above this many portal tests (a number: 2e11,
    /// 500000000000). The estimate (`work_estimate` in `--json`) grows with the square of the
    /// portals; about 10^8 tests take a second of one core.
    #[arg(long, value_name = "TESTS", value_parser = parse_count)]
    pub max_work: Option<u64>,
    /// Over the memory or work limit, merge clusters into coarser ones until the vis fits instead
    /// of refusing: a looser PVS (never hiding a visible leaf), reported with a warning. Without
    /// `--max-work` it merges down to 2e11 portal tests (under an hour of one core).
    #[arg(long)]
    pub coarsen: bool,
}

/// A count for `--max-work`: a whole number, or a decimal one with an exponent (`2e11`).
fn parse_count(s: &str) -> Result<u64, String> {
    let t = s.trim();
    if let Ok(n) = t.parse::<u64>() {
        return Ok(n);
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..u64::MAX as f64).contains(&v) => Ok(v as u64),
        _ => Err(format!("`{s}` is not a count of portal tests (a number: 2e11, 500000000000)")),
    }
}

impl Default for VisFlags {
    /// The command-line defaults: full vis at level 4, no state file.
    fn default() -> Self {
        Self {
            fast: false,
            level: 4,
            state: None,
            checkpoint_secs: 180,
            stop_after: None,
            max_memory: None,
            max_work: None,
            coarsen: false,
        }
    }
}

impl VisFlags {
    /// The vis options these flags ask for (every core; Ctrl-C stops at the next batch).
    pub fn options(&self) -> VisOptions {
        VisOptions {
            fast: self.fast,
            level: self.level,
            state: self.state.clone(),
            checkpoint_interval: std::time::Duration::from_secs(self.checkpoint_secs.max(1)),
            stop_after: self.stop_after,
            cancel: Some(ctrl_c_flag()),
            max_memory: self.max_memory,
            max_work: self.max_work,
            coarsen: self.coarsen,
            ..VisOptions::default()
        }
    }
}

/// What `sightline vis` reports (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// Input file (a base name resolved to its `.bsp`).
    pub input: String,
    /// File written (the `.bsp` itself, or the `.vis`).
    pub output: String,
    /// Portal file format (`PRT1`, `PRT2`, `PRT1-AM`).
    pub prt_format: String,
    /// Under `--portals-from-bsp`: the counts of the portals rebuilt from the tree.
    pub portals_rebuilt: Option<sightline_compiler::bsp_portals::BspPortalStats>,
    /// Vis statistics (leaves, clusters, visible counts, chains, phase times).
    pub vis: VisStats,
    /// Bytes of compressed PVS rows written.
    pub compressed_bytes: usize,
    /// The far plane applied, when one was.
    pub farplane: Option<f64>,
    /// Cluster pairs the far plane hid from each other.
    pub farplane_hidden_pairs: u64,
    /// Ambient sounds switched off (`water`, `sky`, `slime`, `lava`).
    pub ambient_off: Vec<&'static str>,
    /// The `NAME.texinfo.json` whose `noambient` flags were used.
    pub texinfo_json: Option<String>,
    /// Texinfos it flags `noambient`.
    pub noambient_texinfos: usize,
    /// Seconds reading inputs.
    pub read_seconds: f64,
    /// Seconds compressing and writing.
    pub write_seconds: f64,
    /// Total seconds.
    pub total_seconds: f64,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    let path = resolve_input(&args.input);
    // Every `IBSP` (Quake 2 and Quake 3) starts like Quake 2.
    let q2 = starts_like_q2(&path);
    vis_external::check_flags(args, &path, q2)?;
    if args.external_vis && path.is_dir() {
        return vis_external::run_folder(args, &path);
    }
    if super::vis_q3::starts_like_q3(&path) {
        return super::vis_q3::run(args, &path, t0);
    }
    if q2 {
        return run_q2(args, &path, t0);
    }
    if args.phs_only {
        bail!("{}: --phs-only needs a Quake 2 .bsp (IBSP 38)", path.display());
    }
    let (input, rebuilt) = vis_external::read_input(args, &path)?;
    let farplane = args.farplane.filter(|&d| d > 0.0);
    if farplane.is_some() && input.bsp.is_none() {
        bail!(
            "{}: --farplane needs the .bsp (its leaf bounds bound what each cluster holds); run vis on the .bsp",
            path.display()
        );
    }
    let ambient = input.ambient_options(args.ambient_off());
    let texinfo_side = input.bsp.as_ref().and_then(|b| b.texinfo_json.as_ref());
    if let Some(side) = texinfo_side.filter(|s| !s.matches) {
        eprintln!(
            "warning: {} names texinfo {} but the BSP has {}: it belongs to another compile, its flags are ignored",
            side.path.display(),
            side.flags.max_texinfo.unwrap_or(0),
            input.bsp.as_ref().map_or(0, |b| b.bsp.texinfo.len())
        );
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    remove_state(args)?;
    let opts = VisOptions { threads: args.threads, ..args.vis.options() };
    let mut result = compute(&input.prt, &opts, args.json || args.no_progress, &path)?;
    let mut farplane_hidden_pairs = 0;
    if let (Some(d), Some(b)) = (farplane, &input.bsp) {
        let boxes = visdata::cluster_boxes(&b.bsp, &input.prt);
        farplane_hidden_pairs = vis::farplane::cull(&mut result, &boxes, d)?;
    }
    let t1 = Instant::now();
    let rows = Rows::new(&result);
    let output = match &input.bsp {
        Some(b) if args.external_vis => {
            vis_external::write_single(args, &path, b, &result, &rows, &ambient, t0)?
        }
        Some(b) => {
            let out = visdata::write_into_bsp_with(&b.bytes, &b.bsp, &result, &rows, &ambient)?;
            crate::output::write(&path, &out, t0)?;
            path.clone()
        }
        None => {
            let vis_path = path.with_extension("vis");
            crate::output::write(&vis_path, &rows.vis_file()?, t0)?;
            vis_path
        }
    };
    let used_side = texinfo_side.filter(|s| s.matches);
    let report = Report {
        input: path.display().to_string(),
        output: output.display().to_string(),
        prt_format: input.prt.format.header().to_string(),
        portals_rebuilt: rebuilt,
        vis: result.stats.clone(),
        compressed_bytes: rows.data.len(),
        farplane,
        farplane_hidden_pairs,
        ambient_off: [Ambient::Water, Ambient::Sky, Ambient::Slime, Ambient::Lava]
            .into_iter()
            .filter(|a| ambient.off[a.index()])
            .map(ambient_name)
            .collect(),
        texinfo_json: used_side.map(|s| s.path.display().to_string()),
        noambient_texinfos: used_side.map_or(0, |s| s.flags.noambient.len()),
        read_seconds,
        write_seconds: t1.elapsed().as_secs_f64(),
        total_seconds: t0.elapsed().as_secs_f64(),
    };
    crate::out::report(args.json, &report, || text_report(&report))?;
    Ok(Outcome::Clean)
}

/// Deletes the `--state` file under `--no-state`.
pub(crate) fn remove_state(args: &Args) -> anyhow::Result<()> {
    if args.no_state
        && let Some(state) = &args.vis.state
    {
        match std::fs::remove_file(state) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                return Err(e).with_context(|| format!("cannot delete {} (--no-state)", state.display()));
            }
        }
    }
    Ok(())
}

/// The first 8 bytes of the file at `path` (magic and version), or `None` when it has fewer or
/// cannot be read (the readers report that properly later).
pub(crate) fn file_head(path: &Path) -> Option<[u8; 8]> {
    use std::io::Read;
    let mut head = [0u8; 8];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut head)).ok().map(|()| head)
}

/// True when `path` is a file that starts with `IBSP` (Quake 2, and Quake 3 too).
fn starts_like_q2(path: &Path) -> bool {
    file_head(path).is_some_and(|h| q2::is_q2(&h))
}

/// What `sightline vis` reports for a Quake 2 `.bsp` (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Q2Report {
    /// Input (and output) file.
    pub input: String,
    /// Always `"quake2"`.
    pub game: &'static str,
    /// `"vis"` (PVS from the `.prt`, then PHS) or `"phs-only"`.
    pub mode: &'static str,
    /// The portal file read (not under `--phs-only`).
    pub prt: Option<String>,
    /// Vis statistics (not under `--phs-only`).
    pub vis: Option<VisStats>,
    /// Clusters.
    pub clusters: usize,
    /// Ordered visible cluster pairs (self included) of the PVS.
    pub pvs_pairs: u64,
    /// Ordered cluster pairs of the PHS written.
    pub phs_pairs: u64,
    /// Under `--phs-only`: PHS rows that changed, and bits added and removed.
    pub phs_repair: Option<phs::PhsRepair>,
    /// `--farplane` distance, when given.
    pub farplane: Option<f64>,
    /// Cluster pairs (unordered) the far plane hid.
    pub farplane_hidden_pairs: Option<u64>,
    /// Bytes of the visibility lump written.
    pub visibility_bytes: usize,
    /// Total seconds.
    pub total_seconds: f64,
}

/// `sightline vis` on a Quake 2 `.bsp`: the PVS over clusters from the `.prt` beside it (qbsp's
/// PRT1 names clusters), the PHS ([`phs::phs`]), the visibility lump written back; or, under
/// `--phs-only`, only the PHS recomputed from the PVS in the file.
fn run_q2(args: &Args, path: &Path, t0: Instant) -> anyhow::Result<Outcome> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let file = q2::read(&bytes).with_context(|| format!("{}", path.display()))?;
    q2::check_vis_layout(&file.lumps).with_context(|| format!("{}", path.display()))?;
    let farplane = args.farplane.filter(|&d| d > 0.0);
    if args.phs_only && farplane.is_some() {
        bail!("{}: --farplane changes the PVS, which --phs-only keeps byte for byte", path.display());
    }
    let (out, report) = if args.phs_only {
        let (out, repair) = phs::repair_phs(&bytes).with_context(|| format!("{}", path.display()))?;
        let report = Q2Report {
            input: path.display().to_string(),
            game: "quake2",
            mode: "phs-only",
            prt: None,
            vis: None,
            clusters: repair.clusters,
            pvs_pairs: repair.pvs_pairs,
            phs_pairs: repair.phs_pairs,
            phs_repair: Some(repair),
            farplane: None,
            farplane_hidden_pairs: None,
            visibility_bytes: 0,
            total_seconds: 0.0,
        };
        (out, report)
    } else {
        let tried = sightline_formats::prt::beside_bsp(path);
        let Some(prt_path) = tried.iter().find(|p| p.is_file()) else {
            bail!("{}: no portal file beside it (tried {:?})", path.display(), tried);
        };
        let prt_bytes =
            std::fs::read(prt_path).with_context(|| format!("cannot read {}", prt_path.display()))?;
        let prt = sightline_formats::prt::read_bytes(&prt_bytes, &prt_path.display().to_string())?;
        let clusters = file.leaf_cluster_count();
        if prt.format != PrtFormat::Prt1 || prt.num_leaves as usize != clusters {
            bail!(
                "{}: {} with {} leaves does not match the {clusters} clusters of {} (Quake 2 qbsp writes PRT1 over clusters)",
                prt_path.display(),
                prt.format.header(),
                prt.num_leaves,
                path.display()
            );
        }
        remove_state(args)?;
        let opts = VisOptions { threads: args.threads, ..args.vis.options() };
        let mut result = compute(&prt, &opts, args.json || args.no_progress, path)?;
        let mut farplane_hidden_pairs = None;
        if let Some(d) = farplane {
            let level = q2::to_level(&bytes, &file).with_context(|| format!("{}", path.display()))?;
            let boxes = visdata::level_cluster_boxes(&level, &prt);
            farplane_hidden_pairs = Some(vis::farplane::cull(&mut result, &boxes, d)?);
        }
        let n = clusters;
        let mut rows = Vec::with_capacity(n * sightline_formats::bits::bytes::len(n));
        let mut row = Vec::new();
        for leaf in 0..n {
            result.leaf_row_bytes(leaf, &mut row);
            rows.extend_from_slice(&row);
        }
        let words = sightline_formats::bits::words(n);
        let pvs = phs::words_from_bytes(&rows, n);
        let phs_rows = phs::phs(&pvs, words, n);
        let lump = phs::q2_vis_lump(&pvs, &phs_rows, words, n)?;
        let out = q2::write_with_visibility(&bytes, &lump).with_context(|| format!("{}", path.display()))?;
        let report = Q2Report {
            input: path.display().to_string(),
            game: "quake2",
            mode: "vis",
            prt: Some(prt_path.display().to_string()),
            vis: Some(result.stats.clone()),
            clusters: n,
            pvs_pairs: sightline_formats::bits::count(&pvs),
            phs_pairs: sightline_formats::bits::count(&phs_rows),
            phs_repair: None,
            farplane,
            farplane_hidden_pairs,
            visibility_bytes: 0,
            total_seconds: 0.0,
        };
        (out, report)
    };
    crate::output::write(path, &out, t0)?;
    let visibility_bytes = q2::read_header(&out).map_or(0, |l| l[q2::lump::VISIBILITY].length);
    let report = Q2Report { visibility_bytes, total_seconds: t0.elapsed().as_secs_f64(), ..report };
    crate::out::report(args.json, &report, || q2_text_report(&report))?;
    Ok(Outcome::Clean)
}

fn q2_text_report(r: &Q2Report) -> String {
    let mut s = format!("{} (Quake 2, {}): {} clusters\n", r.input, r.mode, r.clusters);
    if let Some(v) = &r.vis {
        let mode =
            if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
        s += &format!(
            "vis {mode}, {} threads, {} portals; base {:.3} s, flow {:.3} s\n",
            v.threads, v.portals, v.base_seconds, v.flow_seconds
        );
    }
    if let (Some(d), Some(hidden)) = (r.farplane, r.farplane_hidden_pairs) {
        s += &format!("far plane {d}: {hidden} cluster pairs hidden\n");
    }
    s += &format!("PVS pairs {}, PHS pairs {}\n", r.pvs_pairs, r.phs_pairs);
    if let Some(f) = &r.phs_repair {
        s += &format!(
            "PHS repaired: {} of {} rows changed, {} bits added, {} removed; PVS rows kept byte for byte\n",
            f.rows_fixed, f.clusters, f.bits_added, f.bits_removed
        );
    }
    s += &format!(
        "visibility lump: {} bytes -> {}\ntime: total {:.3} s\n",
        r.visibility_bytes, r.input, r.total_seconds
    );
    s
}

/// What to tell the user when vis stopped on request after `done` of `total` flow portals, with or
/// without a state file to resume from. A stop by Ctrl-C is announced first ([`announce_stop`]),
/// if no progress report did: the signal may land after a batch's last report and before vis
/// checks the flag at its end.
pub(crate) fn interrupted(done: usize, total: usize, saved: bool) -> String {
    announce_stop();
    if saved {
        format!("stopped after {done} of {total} portals; run again with the same --state to resume")
    } else {
        format!(
            "stopped after {done} of {total} portals; nothing was saved (give --state FILE to make a run resumable)"
        )
    }
}

/// The flag Ctrl-C sets, once a vis options builder asked for it ([`ctrl_c_flag`]).
static CTRL_C: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// A flag set by Ctrl-C, so vis stops at the next batch boundary and saves its state. A second
/// Ctrl-C, once the flag is set, ends the process at once (exit 130). The handler only sets the
/// flag (no thread waits for the signal); progress reports say that the stop is under way
/// ([`announce_stop`]). If a handler cannot be installed, Ctrl-C keeps its default effect (the
/// flag then never turns on).
fn ctrl_c_flag() -> Arc<AtomicBool> {
    CTRL_C
        .get_or_init(|| {
            let flag = Arc::new(AtomicBool::new(false));
            use signal_hook::consts::SIGINT;
            // Handlers run in the order registered: the exit looks at the flag before it is set.
            if signal_hook::flag::register_conditional_shutdown(SIGINT, 130, flag.clone()).is_ok() {
                let _ = signal_hook::flag::register(SIGINT, flag.clone());
            }
            flag
        })
        .clone()
}

/// Says once on stderr, after Ctrl-C has set the flag, that the run is stopping. Every progress
/// report of `vis` and `compile` calls it (a signal handler cannot print).
pub(crate) fn announce_stop() {
    static SAID: AtomicBool = AtomicBool::new(false);
    if CTRL_C.get().is_some_and(|f| f.load(Ordering::Relaxed)) && !SAID.swap(true, Ordering::Relaxed) {
        eprintln!("\ninterrupt: stopping at the next batch of portals (Ctrl-C again to quit now)");
    }
}

/// Run vis with a progress bar (hidden under `--json` or without a terminal). Errors name `file`,
/// the input the user gave.
pub(crate) fn compute(
    prt: &PortalFile,
    opts: &VisOptions,
    quiet: bool,
    file: &Path,
) -> anyhow::Result<VisResult> {
    let base = crate::progress::bar("base", 0, quiet);
    let flow = crate::progress::bar("flow", 0, quiet);
    // Bars are updated every 32 portals (and at the end): an update per portal cost a third of
    // the flow time on small maps. Hidden bars are not updated at all.
    let report = |p: VisProgress| {
        announce_stop();
        if p.phase == VisPhase::Coarsen {
            // Said at once: a merged run may still take long, and its PVS is looser.
            eprintln!(
                "note: vis does not fit its memory or work limit: merging {} clusters into {} (--coarsen)",
                p.total, p.done
            );
            return;
        }
        if quiet || (!p.done.is_multiple_of(32) && p.done != p.total) {
            return;
        }
        let bar = if p.phase == VisPhase::Base { &base } else { &flow };
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
    };
    let result = vis::run(prt, opts, &report);
    base.finish_and_clear();
    flow.finish_and_clear();
    match result {
        Ok(r) => {
            if let Some(c) = &r.stats.coarsened {
                eprintln!(
                    "warning: vis did not fit its memory or work limit: merged {} clusters into {} ({} of {} portals left, estimates {} and {:.1e} portal tests); the PVS is looser",
                    c.clusters_before,
                    c.clusters_after,
                    c.portals_after,
                    c.portals_before,
                    sightline_compiler::memory::format_size(c.estimate),
                    c.work as f64
                );
            }
            Ok(r)
        }
        Err(vis::VisError::Interrupted { done, total }) => {
            bail!(interrupted(done, total, opts.state.is_some()))
        }
        Err(e) => Err(anyhow::Error::new(e).context(file.display().to_string())),
    }
}

fn ambient_name(a: Ambient) -> &'static str {
    match a {
        Ambient::Water => "water",
        Ambient::Sky => "sky",
        Ambient::Slime => "slime",
        Ambient::Lava => "lava",
    }
}

fn text_report(r: &Report) -> String {
    let v = &r.vis;
    let mut extra = String::new();
    if let Some(d) = r.farplane {
        extra += &format!("far plane {d}: {} cluster pairs hidden\n", r.farplane_hidden_pairs);
    }
    if !r.ambient_off.is_empty() {
        extra += &format!("ambient sounds off: {}\n", r.ambient_off.join(", "));
    }
    if let Some(t) = &r.texinfo_json {
        extra += &format!("{t}: {} texinfos make no ambient sound\n", r.noambient_texinfos);
    }
    if let Some(s) = &r.portals_rebuilt {
        extra += &crate::cmd::portals::stats_line(s);
    }
    let mode = if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
    format!(
        "{input} ({fmt}): {leaves} leaves, {clusters} clusters, {portals} portals{dropped}\n\
         vis {mode}, {threads} threads\n\
         visible leaves: average {avg:.1} ({pct:.1} %), median {med}, max {max}; base vis average {might:.1}\n\
         portal chains visited: {chains}{resumed}\n\
         {extra}\
         compressed PVS: {bytes} bytes -> {output}\n\
         time: read {read:.3} s, base {base:.3} s, flow {flow:.3} s, rows {rows:.3} s, write {write:.3} s, total {total:.3} s\n",
        input = r.input,
        fmt = r.prt_format,
        leaves = v.leaves,
        clusters = v.clusters,
        portals = v.portals,
        dropped = if v.dropped_portals > 0 {
            format!(" ({} without area dropped)", v.dropped_portals)
        } else {
            String::new()
        },
        threads = v.threads,
        avg = v.avg_visible,
        pct = v.percent_visible,
        med = v.median_visible,
        max = v.max_visible,
        might = v.avg_mightsee,
        chains = v.chains,
        resumed = if v.resumed_portals > 0 {
            format!(" ({} portals resumed from the state file)", v.resumed_portals)
        } else {
            String::new()
        },
        bytes = r.compressed_bytes,
        output = r.output,
        read = r.read_seconds,
        base = v.base_seconds,
        flow = v.flow_seconds,
        rows = v.rows_seconds,
        write = r.write_seconds,
        total = r.total_seconds,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn translate(words: &[&str]) -> Result<Vec<String>, String> {
        let words: Vec<OsString> = words.iter().map(OsString::from).collect();
        let takes_value = |long: &str| matches!(long, "threads" | "state" | "level" | "farplane");
        let out = ericw_args(&words, &takes_value, &['h', 'V'])?;
        Ok(out.into_iter().map(|w| w.into_string().expect("utf-8")).collect())
    }

    #[test]
    fn ericw_options_become_long_flags_and_the_rest_passes_through() {
        assert_eq!(
            translate(&["-threads", "4", "-Fast", "e1m1", "-level", "2", "-noambientsky", "-visdist", "900"]),
            Ok(["--threads", "4", "--fast", "e1m1", "--level", "2", "--no-ambient-sky", "--farplane", "900"]
                .map(String::from)
                .to_vec())
        );
        // Ignored options vanish, with their value where they take one.
        assert_eq!(
            translate(&[
                "-v",
                "-nolog",
                "-lowpriority",
                "1",
                "-basedir",
                "/q",
                "e1m1",
                "-lowpriority",
                "-nopercent"
            ]),
            Ok(vec!["e1m1".to_string()])
        );
        // Sightline's own flags and their values are never rewritten, nor anything after `--`;
        // clap's short flags and negative numbers pass.
        assert_eq!(
            translate(&["--state", "-odd-name", "--threads=2", "-h", "--", "-fast", "-x"]),
            Ok(["--state", "-odd-name", "--threads=2", "-h", "--", "-fast", "-x"].map(String::from).to_vec())
        );
        assert_eq!(translate(&["-farplane", "-5"]), Ok(vec!["--farplane".into(), "-5".into()]));
        assert_eq!(translate(&["-1.5"]), Ok(vec!["-1.5".into()]));
    }

    #[test]
    fn unknown_options_and_missing_values_are_errors_naming_them() {
        let err = translate(&["e1m1", "-bogus"]).expect_err("unknown");
        assert!(err.contains("`-bogus`"), "{err}");
        let err = translate(&["e1m1", "-threads"]).expect_err("no value");
        assert!(err.contains("`-threads`") && err.contains("value"), "{err}");
        assert!(translate(&["-gamedir"]).is_err());
        assert!(translate(&["-"]).is_ok(), "a lone dash is a word, not an option");
    }

    #[test]
    fn a_base_name_resolves_to_its_bsp() {
        let dir = std::env::temp_dir().join(format!("sightline-vis-resolve-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        for f in ["a.bsp", "b.final.bsp", "c", "c.bsp"] {
            std::fs::write(dir.join(f), b"").expect("write");
        }
        let r =
            |name: &str| resolve_input(&dir.join(name)).file_name().map(|n| n.to_string_lossy().into_owned());
        assert_eq!(r("a").as_deref(), Some("a.bsp"));
        assert_eq!(r("b.final").as_deref(), Some("b.final.bsp"));
        assert_eq!(r("c").as_deref(), Some("c"), "an existing file is taken as it is");
        assert_eq!(r("a.prt").as_deref(), Some("a.prt"), "named inputs are never rewritten");
        assert_eq!(r("none").as_deref(), Some("none"), "nothing to resolve: the error names the input");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
