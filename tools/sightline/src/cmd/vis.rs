//! `sightline vis`: the drop-in vis of any compiled Quake-family map or portal file, run by the
//! library ([`sightline_compiler::dropin`]: every game, the portals given or rebuilt, the PVS with
//! the PHS, ambient levels and far plane as the game has them, written back atomically). This
//! module parses the arguments (ericw-tools' and id's command lines too, [`ericw`]), draws
//! progress, turns Ctrl-C into a stop, and prints the report ([`text`], or JSON).

mod ericw;
pub mod shards;
mod text;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::bail;

use sightline_compiler::bsp_portals::BspPortalOptions;
use sightline_compiler::dropin::{self, DropInError, DropInOptions, Report};
use sightline_compiler::vis::VisError;
use sightline_compiler::vis::shard::MergeSpec;
use sightline_formats::texture::Ambient;
use sightline_job::progress::Progress;

pub use ericw::{ericw_args, single_dash_name};

use crate::interrupt::interrupted;
use crate::outcome::Outcome;
use crate::progress::Bars;
use crate::vis_flags::VisFlags;

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
logging options are accepted and ignored.

Across machines: `sightline vis plan|shard|merge|status` (see `sightline vis shard --help`) split the \
flow into shard files and merge them into the map, byte for byte as `sightline vis --waves W` writes it.")]
pub struct Args {
    /// A Quake, Half-Life or Quake 2 `.bsp` (its `.prt` must sit beside it), a base name (`e1m1`
    /// for `e1m1.bsp`), or a `.prt` file.
    pub input: PathBuf,
    /// Worker threads, 0 to 1024 (0: every core, or one for a map small enough to take
    /// milliseconds). The result is the same for any count.
    #[arg(long, default_value_t = 0, value_parser = crate::limits::threads_or_auto())]
    pub threads: usize,
    /// Vis options.
    #[command(flatten)]
    pub vis: VisFlags,
    /// Flow in this many waves, as a shard plan of that many waves does (`sightline vis plan`):
    /// the result equals the merge of the plan's shards, byte for byte. Default: the usual
    /// batches (a tighter PVS than few waves).
    #[arg(long, value_name = "W", value_parser = clap::value_parser!(u32).range(1..=i64::from(sightline_compiler::vis::plan::MAX_WAVES)))]
    pub waves: Option<u32>,
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

/// The file a `vis` input names: `NAME.bsp` for a base name `NAME` (not a file itself, not
/// ending in `.bsp` or `.prt`, and `NAME.bsp` is a file; `e1m1` or `e1m1.final`), else the input
/// itself.
pub fn resolve_input(input: &Path) -> PathBuf {
    let tried = input_candidates(input);
    tried.iter().find(|p| p.is_file()).unwrap_or(&tried[0]).clone()
}

/// The files [`resolve_input`] looks at, in order: `input` itself, then `input.bsp` when `input`
/// is a base name (not a file itself, not ending in `.bsp` or `.prt`).
fn input_candidates(input: &Path) -> Vec<PathBuf> {
    let named =
        input.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp") || e.eq_ignore_ascii_case("prt"));
    let mut tried = vec![input.to_path_buf()];
    if !named && !input.is_file() {
        let mut bsp = input.as_os_str().to_owned();
        bsp.push(".bsp");
        tried.push(PathBuf::from(bsp));
    }
    tried
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    run_with(args, None)
}

/// The library's options for `args` (the input's output file left to the caller).
pub(crate) fn drop_in_options(args: &Args) -> DropInOptions {
    DropInOptions {
        vis: sightline_compiler::vis::VisOptions {
            threads: args.threads,
            waves: args.waves,
            ..args.vis.options()
        },
        farplane: args.farplane,
        ambient_off: args.ambient_off(),
        phs_only: args.phs_only,
        portals_from_tree: args.portals_from_bsp.then(|| BspPortalOptions {
            liquids: args.water.unwrap_or_default().into(),
            no_clusters: args.no_clusters,
        }),
        restart: args.no_state,
        external_vis: None,
    }
}

/// Run the command, with the flow rows taken from a plan's shard files when `merge` is given
/// (`sightline vis merge`): everything else, the output written included, as the command does.
pub(crate) fn run_with(args: &Args, merge: Option<MergeSpec>) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    let path = resolve_input(&args.input);
    let tried = input_candidates(&args.input);
    if tried.len() > 1 && !path.exists() {
        let tried: Vec<String> = tried.iter().map(|p| p.display().to_string()).collect();
        bail!("{}: no such map; looked for {}", args.input.display(), tried.join(" and "));
    }
    check_flags(args, &path)?;
    let mut opts = drop_in_options(args);
    if merge.is_some() && path.is_dir() {
        bail!("{}: a merge writes one map; name its .bsp or .prt", path.display());
    }
    opts.vis.merge = merge;
    let quiet = args.json || args.no_progress;
    if args.external_vis && path.is_dir() {
        let Some(out) = &args.output else { bail!("{}: folder mode needs -o", path.display()) };
        let report = with_progress(true, &opts, |progress| dropin::pack(&path, out, &opts, progress))?;
        crate::out::report(args.json, &report, || text::pack(&report))?;
        return Ok(if report.skipped.is_empty() { Outcome::Clean } else { Outcome::Finding });
    }
    let opts = DropInOptions {
        external_vis: args
            .external_vis
            .then(|| args.output.clone().unwrap_or_else(|| path.with_extension("vis"))),
        ..opts
    };
    let report = with_progress(quiet, &opts, |progress| dropin::run(&path, &opts, progress, t0))?;
    match &report {
        Report::Quake(r) => {
            crate::out::report(args.json, r, || text::quake(r) + &text::merged(Some(&r.vis)))?
        }
        Report::Quake2(r) => {
            crate::out::report(args.json, r, || text::quake2(r) + &text::merged(r.vis.as_ref()))?;
        }
        Report::Quake3(r) => {
            crate::out::report(args.json, r, || text::quake3(r) + &text::merged(Some(&r.vis)))?
        }
    }
    Ok(Outcome::Clean)
}

/// Refuses flag combinations of the command line that make no sense together; the library refuses
/// what the input's game cannot use.
fn check_flags(args: &Args, path: &Path) -> anyhow::Result<()> {
    let p = path.display();
    if (args.water.is_some() || args.no_clusters) && !args.portals_from_bsp {
        bail!(
            "{p}: --water and --no-clusters need --portals-from-bsp (a portal file has already decided which portals exist)"
        );
    }
    if args.output.is_some() && !args.external_vis {
        bail!("{p}: -o needs --external-vis (otherwise vis writes into the .bsp, or NAME.vis for a .prt)");
    }
    if path.is_dir() && (args.portals_from_bsp || args.external_vis) {
        if !args.external_vis {
            bail!("{p}: a folder needs --external-vis (it makes one external .vis pack of every .bsp in it)");
        }
        if args.output.is_none() {
            bail!(
                "{p}: name the pack with -o (engines read maps/NAME.vis, then GAMEDIR.vis in the game folder: \
                 -o id1/id1.vis, for example)"
            );
        }
    }
    Ok(())
}

/// Runs `work` with progress bars (hidden when `quiet` or without a terminal; notes and warnings,
/// such as a vis merged to fit its limits, said as they come), and turns the library's errors
/// into what the user reads: a stop by Ctrl-C says how to resume.
fn with_progress<T>(
    quiet: bool,
    opts: &DropInOptions,
    work: impl FnOnce(&dyn Progress) -> Result<T, DropInError>,
) -> anyhow::Result<T> {
    // Bars are updated every 32 portals (and at the end): an update per portal cost a third of
    // the flow time on small maps. Hidden bars are not updated at all.
    let bars = Bars::batched(quiet, 32);
    work(&bars).map_err(|e| match e.vis() {
        Some(&VisError::Interrupted { done, total }) => {
            anyhow::anyhow!(interrupted(done, total, opts.vis.state.is_some()))
        }
        _ => e.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
