//! `sightline render`: pictures of a level as PNG.
//!
//! Exactly one mode: `--view` (first person, with `--look`), `--plan` (top-down, with `--from`),
//! `--leak` (the plan with a pointfile's path) or `--pvs-matrix`.
//!
//! Besides `.bsp` and `.slvl`, the input may be a `.map`: it is compiled here without vis (leaks
//! allowed), so a leaking map can be drawn with the leak path its compile found (`--leak` without
//! a file). Pictures of a `.map` have no PVS (everything visible).

use std::ops::Bound::Excluded;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use glam::DVec3;

use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_formats::Level;
use sightline_job::input::read_input;

use crate::limits::{self, MAX_RAYS};
use crate::outcome::Outcome;
use crate::progress::Bars;
use sightline_validate::bsp::BspTree;
use sightline_validate::render::plan::{PlanOptions, render_plan};
use sightline_validate::render::view::{Camera, render_view};
use sightline_validate::render::{matrix, read_pointfile};
use sightline_validate::{self as validate, Options, OracleChoice, load, pvs};

/// What `sightline render` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Render a level or BSP to PNG: first-person, plan, leak path or PVS matrix";

/// Arguments of `sightline render`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// A Quake `.bsp`, a Sightline `.slvl`, or a `.map` (compiled without vis).
    pub input: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// First-person view from this eye position `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub view: Option<String>,
    /// View angles `yaw,pitch` in degrees (yaw from +x towards +y, pitch positive up).
    #[arg(long, value_name = "YAW,PITCH", allow_hyphen_values = true)]
    pub look: Option<String>,
    /// Horizontal field of view in degrees, in (0, 179).
    #[arg(long, default_value_t = 90.0, value_parser = limits::float_in::<f64>((Excluded(0.0), Excluded(179.0)), "a field of view in degrees"))]
    pub fov: f64,
    /// Image size `WxH` of a view, each side 1 to 8192 (a plan uses W and its own aspect).
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = size)]
    pub size: (u32, u32),
    /// In a view, paint anything outside the eye cluster's PVS bright red (exit 1 if any).
    #[arg(long)]
    pub pvs: bool,
    /// Top-down plan of the leaves in a z slab, seen from `--from`.
    #[arg(long)]
    pub plan: bool,
    /// Eye position `x,y,z` of a plan.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub from: Option<String>,
    /// The slab `z0..z1` of a plan (default: 64 units below to 64 above the eye; for a leak
    /// without an eye, 8 units either side of the leak's start).
    #[arg(long, value_name = "Z0..Z1", allow_hyphen_values = true)]
    pub z: Option<String>,
    /// A `.prt` file whose portals a plan draws (the level's own portals are always drawn).
    #[arg(long)]
    pub prt: Option<PathBuf>,
    /// A plan with the leak path of this pointfile (`.pts`) drawn from entity to void; without a
    /// file (for a `.map` input) the path the compile found.
    #[arg(long, value_name = "MAP.PTS", num_args = 0..=1, default_missing_value = "")]
    pub leak: Option<String>,
    /// The cluster-by-cluster PVS matrix.
    #[arg(long)]
    pub pvs_matrix: bool,
    /// With `--pvs-matrix`: sample this many rays (tree oracle, as `validate`) and colour the
    /// pairs they prove green, the other PVS pairs grey and sampled pairs missing from the PVS red.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_RAYS))]
    pub rays: Option<u64>,
}

/// Load a level; a `.map` is compiled without vis (leaks allowed) and also yields its leak path.
fn load_any(path: &std::path::Path) -> anyhow::Result<(Level, Option<Vec<DVec3>>)> {
    let is_map = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("map"));
    if !is_map {
        return Ok((load::load_level(path, &crate::progress::Bars::new(true))?, None));
    }
    let name = path.display().to_string();
    let bytes = read_input(path)?;
    let map = sightline_formats::map::parse_bytes(&bytes, &name)?;
    let opts = CompileOptions { allow_leak: true, ..CompileOptions::default() };
    let compiled = compile(&Source::Map { map, file: name }, &opts, &NoProgress)?;
    Ok((compiled.level, compiled.leak.map(|l| l.path)))
}

/// Parse `x,y,z`.
pub(crate) fn vec3(s: &str, what: &str) -> anyhow::Result<DVec3> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} `{s}`: expected x,y,z"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => bail!("{what} `{s}`: expected three finite numbers x,y,z"),
    }
}

/// Parse `a,b` or `a..b`.
pub(crate) fn pair(s: &str, sep: &str, what: &str) -> anyhow::Result<(f64, f64)> {
    let (a, b) = s.split_once(sep).with_context(|| format!("{what} `{s}`: expected a{sep}b"))?;
    let a: f64 = a.trim().parse().with_context(|| format!("{what} `{s}`"))?;
    let b: f64 = b.trim().parse().with_context(|| format!("{what} `{s}`"))?;
    if !(a.is_finite() && b.is_finite()) {
        bail!("{what} `{s}`: numbers must be finite");
    }
    Ok((a, b))
}

/// Parse `WxH` (`--size`), each side in `1..=MAX_SIDE`.
pub(crate) fn size(s: &str) -> Result<(u32, u32), String> {
    let side = |t: &str| t.trim().parse::<u32>().ok().filter(|v| (1..=MAX_SIDE).contains(v));
    match s.split_once('x').map(|(w, h)| (side(w), side(h))) {
        Some((Some(w), Some(h))) => Ok((w, h)),
        _ => Err(format!("`{s}` is not WxH with each side in 1..={MAX_SIDE}")),
    }
}

/// Widest and tallest picture (the renderers' limit).
const MAX_SIDE: u32 = 8192;

/// Widest PVS matrix picture.
const MATRIX_SIDE: u32 = 2048;

/// Bytes a first-person view takes per pixel while it is drawn and encoded: the rows with the leaf
/// each pixel shows (12), the image (3), the leaf of each pixel (8), the PNG's raw and compressed
/// rows (at most 8).
const VIEW_BYTES_PER_PIXEL: u64 = 32;

/// Bytes a plan or the PVS matrix takes per pixel: its rows (3), the image (3), the PNG's raw and
/// compressed rows (at most 6).
const PLAN_BYTES_PER_PIXEL: u64 = 12;

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let modes = [args.view.is_some(), args.plan, args.leak.is_some(), args.pvs_matrix];
    if modes.iter().filter(|&&m| m).count() != 1 {
        bail!("{}: give exactly one of --view, --plan, --leak, --pvs-matrix", args.input.display());
    }
    // Every number first, then the memory the picture takes, then the files: all before any work.
    let (w, h) = args.size;
    let (yaw, pitch) =
        args.look.as_deref().map(|s| pair(s, ",", "--look")).transpose()?.unwrap_or((0.0, 0.0));
    let eye = args.view.as_deref().map(|s| vec3(s, "--view")).transpose()?;
    let from = args.from.as_deref().map(|s| vec3(s, "--from")).transpose()?;
    let slab = args.z.as_deref().map(|s| pair(s, "..", "--z")).transpose()?;
    // A plan is W wide and as tall as the level's aspect makes it (at most MAX_SIDE); the matrix
    // is at most 2048 square.
    let need = if eye.is_some() {
        u64::from(w) * u64::from(h) * VIEW_BYTES_PER_PIXEL
    } else if args.pvs_matrix {
        u64::from(w.max(h).min(MATRIX_SIDE)).pow(2) * PLAN_BYTES_PER_PIXEL
    } else {
        u64::from(w) * u64::from(MAX_SIDE) * PLAN_BYTES_PER_PIXEL
    };
    let threads = rayon::current_num_threads();
    limits::fits_memory(&format!("a picture of --size {w}x{h}"), need, threads)?;
    let leak_file = args.leak.as_deref().filter(|l| !l.is_empty()).map(Path::new);
    let inputs: Vec<&Path> =
        [Some(args.input.as_path()), args.prt.as_deref(), leak_file].into_iter().flatten().collect();
    crate::output::check(&inputs, &[&args.output])?;
    let (level, compiled_leak) = load_any(&args.input)?;
    // Errors about the level name its file (the libraries only see the level).
    let file = || args.input.display().to_string();
    let tree = BspTree::new(&level).with_context(file)?;
    let pvs = pvs::level_pvs(&level).with_context(file)?;
    let mut outcome = Outcome::Clean;
    let image = if let Some(eye) = eye {
        let camera = Camera { eye, yaw, pitch, fov: args.fov, width: w, height: h };
        let v = render_view(&tree, &camera, args.pvs.then_some(&pvs))?;
        // Red pixels are counted only against the PVS (--pvs); without it there is nothing to say.
        let red = if args.pvs { format!(", {} red pixels", v.red_pixels) } else { String::new() };
        println!(
            "eye leaf {} (cluster {}), {} leaves shown{red}",
            v.eye_leaf,
            v.eye_cluster,
            v.leaves_shown.len()
        );
        if v.red_pixels > 0 {
            outcome = Outcome::Finding;
        }
        v.image
    } else if args.pvs_matrix {
        let sampled = match args.rays {
            Some(rays) => {
                let opts = Options {
                    rays,
                    oracle: OracleChoice::Tree,
                    cancel: crate::interrupt::cancel(),
                    ..Options::default()
                };
                let mut v = validate::validate(&level, &pvs, &opts, &Bars::new(false)).with_context(file)?;
                let misses = v.report.misses();
                println!(
                    "{} pairs proved by {rays} rays, {misses} misses",
                    v.report.oracles[0].sampled_pairs
                );
                if misses > 0 {
                    outcome = Outcome::Finding;
                }
                v.sampled.pop().and_then(|mut steps| steps.pop())
            }
            None => None,
        };
        let image = matrix::render_matrix(&pvs, sampled.as_ref(), w.max(h).min(MATRIX_SIDE));
        if (image.width, image.height) != (w, h) {
            println!(
                "note: the PVS matrix is {0}x{0}, not the {w}x{h} asked: it is square, at most {MATRIX_SIDE} a side, \
                 and gives each of the {1} clusters a whole number of pixels (or each pixel a whole number of clusters)",
                image.width,
                pvs.len()
            );
        }
        image
    } else {
        let leak = match &args.leak {
            Some(p) if p.is_empty() => compiled_leak.with_context(|| {
                format!("{}: --leak without a file needs a leaking .map as input", file())
            })?,
            Some(p) => {
                let bytes = read_input(Path::new(p))?;
                read_pointfile(&String::from_utf8_lossy(&bytes), p)?
            }
            None => Vec::new(),
        };
        let centre_z = from.or(leak.first().copied()).map_or(0.0, |p| p.z);
        let z = match slab {
            Some(z) => z,
            None if from.is_none() && leak.is_empty() => (-1e5, 1e5),
            // A leaking level has open void around it: a thin slab keeps its walls visible.
            None if from.is_none() => (centre_z - 8.0, centre_z + 8.0),
            None => (centre_z - 64.0, centre_z + 64.0),
        };
        let mut portals: Vec<Vec<DVec3>> = level
            .portals
            .iter()
            .filter_map(|p| {
                let first = p.first_vertex as usize;
                level.vertices.get(first..first + p.num_vertices as usize)
            })
            .map(|v| v.iter().map(|c| DVec3::from(c.map(f64::from))).collect())
            .collect();
        if let Some(prt) = &args.prt {
            let bytes = read_input(prt)?;
            let file = sightline_formats::prt::read_bytes(&bytes, &prt.display().to_string())?;
            portals.extend(file.portals.into_iter().map(|p| p.winding.points));
        }
        let camera = match (from, &args.look) {
            (Some(eye), Some(_)) => Some(Camera { eye, yaw, pitch, fov: args.fov, width: w, height: h }),
            _ => None,
        };
        let opts = PlanOptions { from, z, camera, width: w, portals, leak };
        let plan = render_plan(&tree, from.map(|_| &pvs), &opts)?;
        println!("{} PVS leaves, {} in the frustum", plan.pvs_leaves.len(), plan.frustum_leaves.len());
        plan.image
    };
    image.save(&args.output)?;
    println!("wrote {} ({}x{})", args.output.display(), image.width, image.height);
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vectors_pairs_and_sizes() {
        assert_eq!(vec3("1,-2.5, 3", "--view").unwrap(), DVec3::new(1.0, -2.5, 3.0));
        assert!(vec3("1,2", "--view").is_err());
        assert!(vec3("1,2,inf", "--view").is_err());
        assert_eq!(pair("-64..128", "..", "--z").unwrap(), (-64.0, 128.0));
        assert_eq!(pair("90,-10", ",", "--look").unwrap(), (90.0, -10.0));
        assert!(pair("90", ",", "--look").is_err());
        assert_eq!(size("640x480").unwrap(), (640, 480));
        assert!(size("0x480").is_err() && size("640").is_err() && size("99999x2").is_err());
    }
}
