//! Vis across machines: a run split into shard files ([`run_shard`]) that merge
//! ([`VisOptions::merge`](super::VisOptions::merge)) into exactly the rows of the one-process run
//! of the same plan ([`VisOptions::waves`](super::VisOptions::waves)).
//!
//! A plan ([`Plan`], laid out by [`super::plan`]) cuts the processing order into waves and each
//! wave into shards. A shard of wave `w` replays the shard files of the waves before it (their
//! rows and seeds, folded in processing order exactly as the batch boundaries fold them), flows
//! its own portals from that state, and writes their rows, chains, beam-cull flags and the seed
//! pairs they found (new at the wave's start, in `(from, to)` order). A merge replays every wave
//! the same way; since no portal of a wave reads another of the same wave, the folded rows are
//! those of the run in batches of one wave, whatever the shard count and thread counts.
//!
//! A shard file is sealed like a `--state` file (bincode 2, checksum trailer, decoding bounded by
//! the file's length, written atomically): a shard file starts with its magic and the identity of
//! what it belongs to, a hash ([`fnv1a`]) of the portal file as vis reads it (its text as
//! [`sightline_formats::prt::write`] prints it: the same for a `.bsp` before and after its
//! visdata is written back), of the options that change rows (level, seeds), of the plan and of
//! the program's version. A shard is the same bytes however often it is rerun. Loading checks the
//! identity, its place in the plan and that it holds exactly the portals the plan gives it; any
//! failure is a [`VisError::Shard`] naming the file.
//!
//! A partial merge ([`MergeSpec::allow_partial`]) leaves the portals of missing shards their
//! base-vis rows (`mightsee`, tightened by symmetry with the rest): a superset of their flow
//! rows, so the PVS stays conservative, only looser ([`MergeStats`]).

use std::borrow::Cow;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use sightline_formats::bits;
use sightline_formats::hash::{FNV_OFFSET, fnv1a};
use sightline_formats::prt::PortalFile;
use sightline_job::atomic::write_file_atomic;
use sightline_job::progress::{Progress, phase};

use super::error::{VisError, panic_error};
use super::options::VisOptions;
use super::plan::{Layout, Plan, PlanReport};
pub use super::plan::{MergeSpec, ShardFiles};
pub use super::stats::MergeStats;
use super::stats::VisStats;
use super::{base, flow, graph, parallel, rows, seeds, state, symmetry};

/// Identifies the shard file format and the flow's rules ("SLVISSH2": certified seeds have a row
/// per portal); a change of what a flow computes takes a new tag, as [`state`]'s does.
const MAGIC: u64 = 0x534c_5649_5353_4832;

/// The program version a shard's identity names.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The contents of a shard file (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ShardFile {
    /// Format tag, [`MAGIC`].
    magic: u64,
    /// Hash of the portal file, the options that change rows, the plan and the version.
    identity: u64,
    /// The plan's shards per wave.
    shards: u32,
    /// The plan's waves.
    waves: u32,
    /// This shard's wave, from 1.
    wave: u32,
    /// This shard's index in its wave, from 1.
    index: u32,
    /// One-way portals of the input.
    portals: u64,
    /// Words per row.
    words: u64,
    /// Clusters (the range of a seed pair's `to`; its `from` is a row of [`seeds::Seeds`]).
    clusters: u64,
    /// The one-way portals flowed, in the plan's order for this shard.
    units: Vec<u32>,
    /// Per unit, `words` words: its flow row.
    rows: Vec<u64>,
    /// Per unit, the chains its flow visited.
    chains: Vec<u64>,
    /// Per unit, whether a beam cull of its flow dropped a portal.
    dropped: Vec<bool>,
    /// Seed pairs `(from, to)` the shard's flows found that the wave's start did not know, in
    /// `(from, to)` order.
    pairs: Vec<[u32; 2]>,
}

/// The identity of shard files for `prt` with `opts` under `plan`, for program `version`.
fn identity(prt: &PortalFile, opts: &VisOptions, plan: Plan, version: &str) -> u64 {
    let text = sightline_formats::prt::write(prt);
    let mut h = fnv1a(&MAGIC.to_le_bytes(), FNV_OFFSET);
    h = fnv1a(text.as_bytes(), h);
    h = fnv1a(&[opts.level, u8::from(opts.seeds)], h);
    h = fnv1a(&plan.shards.to_le_bytes(), h);
    h = fnv1a(&plan.waves.to_le_bytes(), h);
    fnv1a(version.as_bytes(), h)
}

/// What a shard of a run must be.
struct Want<'a> {
    identity: u64,
    plan: Plan,
    wave: u32,
    index: u32,
    portals: usize,
    words: usize,
    clusters: usize,
    units: &'a [u32],
}

/// Why a shard file cannot be used: stale (another input, options, plan or version), damaged or
/// inconsistent. The message names the file.
fn refuse(path: &Path, why: &str) -> VisError {
    VisError::Shard(format!("{}: {why}; delete it and run the shard again", path.display()))
}

/// The shard at `path` if the file exists, checked against `want`.
fn load(path: &Path, want: &Want<'_>) -> Result<Option<ShardFile>, VisError> {
    let bytes = match sightline_job::input::read_input(path) {
        Ok(b) => b,
        Err(e) if e.is_not_found() => return Ok(None),
        Err(e) => {
            let cause = std::error::Error::source(&e).map(|c| format!(": {c}")).unwrap_or_default();
            return Err(VisError::Shard(format!("{e}{cause}")));
        }
    };
    let f: ShardFile = state::unseal(&bytes, MAGIC, "vis shard")
        .map_err(|e| refuse(path, &format!("not a usable vis shard ({e})")))?;
    if f.identity != want.identity {
        return Err(refuse(
            path,
            &format!(
                "the shard belongs to another input, other options, another plan or another version of \
                 sightline (identity {:016x}, this run's is {:016x}; this is version {VERSION})",
                f.identity, want.identity
            ),
        ));
    }
    let place = [
        ("shards", u64::from(f.shards), u64::from(want.plan.shards)),
        ("waves", u64::from(f.waves), u64::from(want.plan.waves)),
        ("wave", u64::from(f.wave), u64::from(want.wave)),
        ("index", u64::from(f.index), u64::from(want.index)),
        ("portal count", f.portals, want.portals as u64),
        ("row words", f.words, want.words as u64),
        ("cluster count", f.clusters, want.clusters as u64),
    ];
    if let Some((field, got, wanted)) = place.iter().find(|(_, got, wanted)| got != wanted) {
        return Err(refuse(path, &format!("header field {field} is {got}, expected {wanted}")));
    }
    let k = f.units.len();
    let problem = if f.units != want.units {
        Some(format!("it holds other portals than the plan gives shard {}/{}", want.index, want.plan.shards))
    } else if f.rows.len() as u64 != k as u64 * f.words || f.chains.len() != k || f.dropped.len() != k {
        Some(format!("the per-portal records do not match its {k} portals"))
    } else if let Some(i) = (0..k).find(|&i| {
        let row = &f.rows[i * want.words..(i + 1) * want.words];
        row.iter().enumerate().any(|(w, &x)| x & !bits::valid_mask(w, want.portals) != 0)
    }) {
        Some(format!("the row of its portal {} has bits past the {} portals", f.units[i], want.portals))
    } else {
        let rows = seeds::Seeds::rows(want.portals, want.clusters);
        f.pairs.iter().find(|&&[from, to]| from as usize >= rows || to as usize >= want.clusters).map(|p| {
            format!("seed pair {p:?} out of range ({} portals, {} clusters)", want.portals, want.clusters)
        })
    };
    match problem {
        Some(p) => Err(refuse(path, &format!("inconsistent vis shard ({p})"))),
        None => Ok(Some(f)),
    }
}

/// A run's state at a wave boundary: what flows read and waves write.
struct Rows {
    test: Vec<u64>,
    seeds: seeds::Seeds,
    quiet: usize,
}

/// What shard commands share: the input checked, base vis, the plan laid out and the rows
/// tightened, ready for wave 1.
struct Prepared<'g> {
    opts: VisOptions,
    g: Cow<'g, graph::Graph>,
    words: usize,
    layout: Layout,
    identity: u64,
    rows: Rows,
}

impl<'g> Prepared<'g> {
    fn new(prt: &PortalFile, opts: &VisOptions, plan: Plan, version: &str) -> Result<Self, VisError> {
        let opts = super::checked(prt, opts)?;
        if opts.fast {
            return Err(VisError::Option("--fast has no flow to shard".to_string()));
        }
        let g = graph::Graph::new(prt);
        let n = g.portals.len();
        let words = bits::words(n);
        let might = base::mightsee(&g, words, opts.threads, &|| {}).rows;
        Ok(Self::from_base(prt, opts, Cow::Owned(g), might, words, plan, version))
    }

    fn from_base(
        prt: &PortalFile,
        opts: VisOptions,
        g: Cow<'g, graph::Graph>,
        might: Vec<u64>,
        words: usize,
        plan: Plan,
        version: &str,
    ) -> Self {
        let n = g.portals.len();
        let layout = Layout::new(plan, &might, words, n);
        let mut test = might;
        symmetry::tighten_all(&mut test, words, n);
        let seeds = seeds::Seeds::new(g.portals.len(), g.num_clusters());
        let identity = identity(prt, &opts, plan, version);
        Self { opts, g, words, layout, identity, rows: Rows { test, seeds, quiet: 0 } }
    }

    fn want(&self, plan: Plan, wave: u32, index: u32) -> Want<'_> {
        Want {
            identity: self.identity,
            plan,
            wave,
            index,
            portals: self.g.portals.len(),
            words: self.words,
            clusters: self.g.num_clusters(),
            units: &self.layout.units[wave as usize - 1][index as usize - 1],
        }
    }

    /// Loads every shard of `wave` (from 1): per shard its file, `None` when missing.
    fn load_wave(&self, files: &ShardFiles, wave: u32) -> Result<Vec<Option<ShardFile>>, VisError> {
        (1..=files.plan.shards).map(|k| load(&files.path(wave, k), &self.want(files.plan, wave, k))).collect()
    }

    /// Folds the shards of `wave` (from 1) into the rows, in processing order, as a batch
    /// boundary folds a batch; the portals of missing shards keep their rows. Returns the
    /// missing portals and the chains of the shards.
    fn fold_wave(&mut self, wave: u32, shards: &[Option<ShardFile>], missing: &mut Vec<u32>) -> u64 {
        let words = self.words;
        let Rows { test, seeds, quiet } = &mut self.rows;
        let cw = bits::words(self.g.num_clusters());
        let known = seeds.known_mut();
        // Per portal of the wave, its shard and place in it.
        let mut at = vec![None; self.g.portals.len()];
        let mut chains = 0u64;
        for (s, f) in shards.iter().enumerate() {
            let Some(f) = f else { continue };
            for &[from, to] in &f.pairs {
                bits::set(&mut known[from as usize * cw..(from as usize + 1) * cw], to as usize);
            }
            for (i, &p) in f.units.iter().enumerate() {
                at[p as usize] = Some((s, i));
            }
            chains = f.chains.iter().fold(chains, |a, &c| a.saturating_add(c));
        }
        for &p in &self.layout.order[self.layout.wave_range(wave as usize - 1)] {
            match at[p] {
                Some((s, i)) => {
                    let Some(f) = &shards[s] else { continue };
                    symmetry::replace_row(test, words, p, &f.rows[i * words..(i + 1) * words]);
                    *quiet = flow::quiet_after(*quiet, f.dropped[i]);
                }
                None => {
                    missing.push(p as u32);
                    *quiet = flow::quiet_after(*quiet, true);
                }
            }
        }
        chains
    }
}

/// Lays `plan` over `prt` (base vis, then the plan's waves and shards): `sightline vis plan`.
pub fn plan(prt: &PortalFile, opts: &VisOptions, plan: Plan) -> Result<PlanReport, VisError> {
    let p = Prepared::new(prt, opts, plan, VERSION)?;
    Ok(p.layout.report(plan))
}

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShardReport {
    /// The file written.
    pub path: String,
    /// Its wave, from 1.
    pub wave: u32,
    /// Its index, from 1.
    pub index: u32,
    /// One-way portals flowed.
    pub portals: usize,
    /// Portal chains visited.
    pub chains: u64,
    /// The plan's estimated cost of the shard.
    pub cost: u64,
    /// Seconds in base vis, replaying earlier waves and flowing.
    pub seconds: f64,
}

/// Flows shard `index` of wave `wave` (both from 1) of `files.plan` for `prt` and writes its file
/// atomically. A wave after the first needs every shard of the waves before it (a
/// [`VisError::Shard`] lists the missing ones). `progress` gets a phase `vis shard`, a step per
/// portal; [`VisOptions::cancel`] stops it between portals ([`VisError::Interrupted`], nothing
/// written).
pub fn run_shard(
    prt: &PortalFile,
    opts: &VisOptions,
    files: &ShardFiles,
    wave: u32,
    index: u32,
    progress: &dyn Progress,
) -> Result<ShardReport, VisError> {
    run_shard_as(prt, opts, files, wave, index, progress, VERSION)
}

fn run_shard_as(
    prt: &PortalFile,
    opts: &VisOptions,
    files: &ShardFiles,
    wave: u32,
    index: u32,
    progress: &dyn Progress,
    version: &str,
) -> Result<ShardReport, VisError> {
    let plan = files.plan;
    if !(1..=plan.waves).contains(&wave) || !(1..=plan.shards).contains(&index) {
        return Err(VisError::Option(format!(
            "shard {index} of wave {wave} is not in a plan of {} shards in {} waves",
            plan.shards, plan.waves
        )));
    }
    let t0 = Instant::now();
    let work = || -> Result<ShardReport, VisError> {
        let mut p = Prepared::new(prt, opts, plan, version)?;
        for w in 1..wave {
            let shards = p.load_wave(files, w)?;
            let absent: Vec<String> = (1..=plan.shards)
                .filter(|&k| shards[k as usize - 1].is_none())
                .map(|k| files.path(w, k).display().to_string())
                .collect();
            if !absent.is_empty() {
                return Err(VisError::Shard(format!(
                    "wave {wave} reads every shard of wave {w}; missing: {}",
                    absent.join(", ")
                )));
            }
            p.fold_wave(w, &shards, &mut Vec::new());
        }
        let units = &p.layout.units[wave as usize - 1][index as usize - 1];
        let flowed = flow_units(&p, units, progress)?;
        let mut pairs = Vec::new();
        p.rows.seeds.fold(|from, to| pairs.push([from, to]));
        let mut rows = Vec::with_capacity(units.len() * p.words);
        let (mut chains, mut dropped) = (Vec::new(), Vec::new());
        for (row, c, d) in flowed {
            rows.extend_from_slice(&row);
            chains.push(c);
            dropped.push(d);
        }
        let file = ShardFile {
            magic: MAGIC,
            identity: p.identity,
            shards: plan.shards,
            waves: plan.waves,
            wave,
            index,
            portals: p.g.portals.len() as u64,
            words: p.words as u64,
            clusters: p.g.num_clusters() as u64,
            units: units.clone(),
            rows,
            chains,
            dropped,
            pairs,
        };
        let path = files.path(wave, index);
        let bytes = state::seal(&file)
            .map_err(|e| VisError::Shard(format!("{}: cannot encode: {e}", path.display())))?;
        std::fs::create_dir_all(&files.dir).map_err(|e| {
            VisError::Shard(format!("{}: cannot create the folder: {e}", files.dir.display()))
        })?;
        write_file_atomic(&path, &bytes).map_err(|e| VisError::Shard(format!("{}: {e}", path.display())))?;
        Ok(ShardReport {
            path: path.display().to_string(),
            wave,
            index,
            portals: units.len(),
            chains: file.chains.iter().sum(),
            cost: p.layout.cost[wave as usize - 1][index as usize - 1],
            seconds: t0.elapsed().as_secs_f64(),
        })
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).map_err(panic_error)?
}

/// A flowed unit: its place in the shard, its row, chains and cull flag.
type Flowed = (usize, Vec<u64>, u64, bool);

/// Flows `units` from the rows of `p` on its threads: per unit its row, chains and cull flag,
/// in the order of `units`. The seeds found stay pending in `p`'s seeds.
fn flow_units(
    p: &Prepared<'_>,
    units: &[u32],
    progress: &dyn Progress,
) -> Result<Vec<(Vec<u64>, u64, bool)>, VisError> {
    let nc = p.g.num_clusters();
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<Flowed>> = Mutex::new(Vec::with_capacity(units.len()));
    let shard_phase = phase(progress, "vis shard", units.len() as u64);
    let trial = flow::trial_after(p.rows.quiet);
    parallel::on_every_thread(p.opts.threads, || {
        let mut f = flow::Flow::new(p.g.portals.len(), nc, p.opts.level, p.opts.seeds);
        let mut mine = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::AcqRel);
            if i >= units.len() || p.opts.cancel.is_cancelled() {
                break;
            }
            let mut row = vec![0u64; p.words];
            f.chains = 0;
            f.run(&p.g, &p.rows.test, &p.rows.seeds, units[i] as usize, trial, &mut row);
            mine.push((i, row, f.chains, f.dropped()));
            shard_phase.advance(1);
        }
        done.lock().unwrap_or_else(PoisonError::into_inner).extend(mine);
    });
    let mut done = done.into_inner().unwrap_or_else(PoisonError::into_inner);
    if done.len() < units.len() {
        return Err(VisError::Interrupted { done: done.len(), total: units.len() });
    }
    done.sort_unstable_by_key(|d| d.0);
    Ok(done.into_iter().map(|(_, row, c, d)| (row, c, d)).collect())
}

/// The state of one shard file ([`status`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "state", content = "reason", rename_all = "lowercase")]
pub enum ShardState {
    /// Present and belongs to this input and plan.
    Done,
    /// Not there.
    Missing,
    /// There but unusable: the reason.
    Stale(String),
}

/// One shard file's state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ShardStatus {
    /// Its wave, from 1.
    pub wave: u32,
    /// Its index, from 1.
    pub index: u32,
    /// Its file.
    pub path: String,
    /// Its state.
    #[serde(flatten)]
    pub state: ShardState,
}

/// The state of every shard file of `files.plan` for `prt`: `sightline vis status`.
pub fn status(prt: &PortalFile, opts: &VisOptions, files: &ShardFiles) -> Result<Vec<ShardStatus>, VisError> {
    let p = Prepared::new(prt, opts, files.plan, VERSION)?;
    let mut out = Vec::new();
    for wave in 1..=files.plan.waves {
        for index in 1..=files.plan.shards {
            let path = files.path(wave, index);
            let state = match load(&path, &p.want(files.plan, wave, index)) {
                Ok(Some(_)) => ShardState::Done,
                Ok(None) => ShardState::Missing,
                Err(e) => ShardState::Stale(e.to_string()),
            };
            out.push(ShardStatus { wave, index, path: path.display().to_string(), state });
        }
    }
    Ok(out)
}

/// The flow rows of `spec`'s shard files, folded wave after wave (in place of the flow of
/// [`super::run`]); `stats` gets their chains and [`VisStats::merged`].
pub(super) fn merge_rows(
    prt: &PortalFile,
    g: &graph::Graph,
    might: Vec<u64>,
    words: usize,
    opts: &VisOptions,
    spec: &MergeSpec,
    stats: &mut VisStats,
) -> Result<Vec<u64>, VisError> {
    let plan = spec.files.plan;
    let mut p = Prepared::from_base(prt, opts.clone(), Cow::Borrowed(g), might, words, plan, VERSION);
    let mut waves = Vec::with_capacity(plan.waves as usize);
    let mut absent = Vec::new();
    for w in 1..=plan.waves {
        let shards = p.load_wave(&spec.files, w)?;
        for (k, f) in shards.iter().enumerate() {
            if f.is_none() {
                absent.push(spec.files.path(w, k as u32 + 1).display().to_string());
            }
        }
        waves.push(shards);
    }
    if !absent.is_empty() && !spec.allow_partial {
        return Err(VisError::Shard(format!(
            "{} of {} shard files missing: {}; run them, or merge with --allow-partial (their portals keep \
             their base vis)",
            absent.len(),
            plan.shards * plan.waves,
            absent.join(", ")
        )));
    }
    let mut missing = Vec::new();
    let mut chains = 0u64;
    for (w, shards) in waves.iter().enumerate() {
        chains = chains.saturating_add(p.fold_wave(w as u32 + 1, shards, &mut missing));
    }
    let mut pairs_from_missing = 0;
    if !missing.is_empty() {
        let threads = rows::rows_threads(prt, words, opts.threads);
        let pairs = |test: &[u64]| {
            let mut s = VisStats::default();
            rows::cluster_rows(prt, &p.g, test, words, threads).fill_stats(&mut s);
            s.visible_pairs
        };
        let mut without = p.rows.test.clone();
        for &m in &missing {
            without[m as usize * words..(m as usize + 1) * words].fill(0);
        }
        pairs_from_missing = pairs(&p.rows.test).saturating_sub(pairs(&without));
    }
    stats.chains = chains;
    stats.merged = Some(MergeStats {
        shards: plan.shards,
        waves: plan.waves,
        missing: absent,
        missing_portals: missing.len(),
        pairs_from_missing,
    });
    Ok(p.rows.test)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_job::progress::NoProgress;

    fn temp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("sightline-shard-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// Every shard of `files.plan` run, on `threads` threads.
    fn run_all(prt: &PortalFile, files: &ShardFiles, threads: usize) {
        let opts = VisOptions { threads, ..VisOptions::default() };
        for w in 1..=files.plan.waves {
            for k in 1..=files.plan.shards {
                run_shard(prt, &opts, files, w, k, &NoProgress).expect("shard");
            }
        }
    }

    fn merged(
        prt: &PortalFile,
        files: &ShardFiles,
        allow_partial: bool,
    ) -> Result<super::super::VisResult, VisError> {
        let spec = MergeSpec { files: files.clone(), allow_partial };
        super::super::run(
            prt,
            &VisOptions { threads: 2, merge: Some(spec), ..VisOptions::default() },
            &NoProgress,
        )
    }

    #[test]
    fn merged_shards_equal_the_one_process_run_of_the_plan_for_any_shard_count() {
        let prt = super::super::tests::grid(9, 7, 11);
        let dir = temp("equal");
        for waves in [1, 3] {
            let one = VisOptions { threads: 2, waves: Some(waves), ..VisOptions::default() };
            let whole = super::super::run(&prt, &one, &NoProgress).expect("one process");
            for (shards, threads) in [(1, 1), (2, 2), (7, 1), (16, 2)] {
                let files = ShardFiles {
                    dir: dir.join(format!("{waves}-{shards}")),
                    stem: "g".into(),
                    plan: Plan::new(shards, waves).expect("plan"),
                };
                run_all(&prt, &files, threads);
                let m = merged(&prt, &files, false).expect("merge");
                assert_eq!(m.rows, whole.rows, "{shards} shards in {waves} waves");
                assert_eq!(m.stats.chains, whole.stats.chains, "{shards} shards in {waves} waves: chains");
                // A shard run again writes the same bytes.
                let path = files.path(waves, shards);
                let before = std::fs::read(&path).expect("read");
                run_shard(
                    &prt,
                    &VisOptions { threads: 3 - threads, ..VisOptions::default() },
                    &files,
                    waves,
                    shards,
                    &NoProgress,
                )
                .expect("rerun");
                assert_eq!(std::fs::read(&path).expect("read"), before, "rerun of {}", path.display());
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_partial_merge_keeps_every_pair_and_status_names_the_missing() {
        let prt = super::super::tests::grid(9, 7, 5);
        let dir = temp("partial");
        let files = ShardFiles { dir: dir.clone(), stem: "g".into(), plan: Plan::new(4, 1).expect("plan") };
        run_all(&prt, &files, 1);
        let full = merged(&prt, &files, false).expect("merge");
        let gone = files.path(1, 3);
        std::fs::remove_file(&gone).expect("remove");
        let opts = VisOptions { threads: 1, ..VisOptions::default() };
        let st = status(&prt, &opts, &files).expect("status");
        let missing: Vec<u32> =
            st.iter().filter(|s| s.state == ShardState::Missing).map(|s| s.index).collect();
        assert_eq!(missing, [3]);
        assert!(st.iter().filter(|s| s.index != 3).all(|s| s.state == ShardState::Done));
        match merged(&prt, &files, false) {
            Err(VisError::Shard(m)) => assert!(m.contains("g.3-of-4.shard"), "{m}"),
            other => panic!("merged without a shard: {other:?}"),
        }
        let partial = merged(&prt, &files, true).expect("partial");
        let ms = partial.stats.merged.clone().expect("merge stats");
        assert_eq!(ms.missing, [gone.display().to_string()]);
        assert!(ms.missing_portals > 0);
        let n = prt.num_clusters as usize;
        for a in 0..n {
            for b in 0..n {
                if full.cluster_sees(a, b) {
                    assert!(partial.cluster_sees(a, b), "the partial merge hides {b} from {a}");
                }
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_later_wave_needs_every_shard_of_the_waves_before_it() {
        let prt = super::super::tests::grid(5, 4, 2);
        let dir = temp("waves");
        let files = ShardFiles { dir: dir.clone(), stem: "w".into(), plan: Plan::new(3, 2).expect("plan") };
        let opts = VisOptions { threads: 1, ..VisOptions::default() };
        for k in [1, 3] {
            run_shard(&prt, &opts, &files, 1, k, &NoProgress).expect("wave 1");
        }
        match run_shard(&prt, &opts, &files, 2, 1, &NoProgress) {
            Err(VisError::Shard(m)) => {
                assert!(m.contains("w.wave1-of-2.2-of-3.shard") && !m.contains("1-of-3"), "{m}");
            }
            other => panic!("wave 2 ran without all of wave 1: {other:?}"),
        }
        assert!(!files.path(2, 1).exists(), "nothing written");
        assert!(run_shard(&prt, &opts, &files, 3, 1, &NoProgress).is_err(), "no wave 3 in 2 waves");
        assert!(run_shard(&prt, &opts, &files, 1, 4, &NoProgress).is_err(), "no shard 4 of 3");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_damaged_shard_is_stale_and_refused_naming_its_file() {
        let prt = super::super::tests::grid(5, 4, 9);
        let dir = temp("damaged");
        let files = ShardFiles { dir: dir.clone(), stem: "d".into(), plan: Plan::new(2, 1).expect("plan") };
        run_all(&prt, &files, 1);
        let path = files.path(1, 2);
        let good = std::fs::read(&path).expect("read");
        let opts = VisOptions { threads: 1, ..VisOptions::default() };
        // Every flipped byte, a cut and an extension: stale in the status, refused by the merge.
        let step = (good.len() / 40).max(1);
        let mut bad: Vec<Vec<u8>> = (0..good.len())
            .step_by(step)
            .map(|i| {
                let mut b = good.clone();
                b[i] ^= 0x20;
                b
            })
            .collect();
        bad.push(good[..good.len() - 1].to_vec());
        bad.push([good.as_slice(), &[0]].concat());
        for b in bad {
            std::fs::write(&path, &b).expect("write");
            let st = status(&prt, &opts, &files).expect("status");
            assert!(matches!(st[1].state, ShardState::Stale(_)), "{:?}", st[1]);
            match merged(&prt, &files, true) {
                Err(VisError::Shard(m)) => assert!(m.contains("d.2-of-2.shard"), "{m}"),
                other => panic!("a damaged shard merged: {other:?}"),
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_shard_of_another_version_is_refused_naming_its_file() {
        let prt = super::super::tests::grid(6, 5, 3);
        let opts = VisOptions { threads: 1, ..VisOptions::default() };
        let dir = temp("version");
        let files = ShardFiles { dir: dir.clone(), stem: "m".into(), plan: Plan::new(2, 1).expect("plan") };
        run_shard_as(&prt, &opts, &files, 1, 1, &NoProgress, "0.0.0-other").expect("shard");
        run_shard(&prt, &opts, &files, 1, 2, &NoProgress).expect("shard");
        let merge =
            VisOptions { merge: Some(MergeSpec { files: files.clone(), allow_partial: false }), ..opts };
        match super::super::run(&prt, &merge, &NoProgress) {
            Err(VisError::Shard(m)) => assert!(m.contains("m.1-of-2.shard") && m.contains("version"), "{m}"),
            other => panic!("a shard of another version merged: {other:?}"),
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
