//! `sightline vis plan|shard|merge|status`: one map's vis across machines
//! ([`sightline_compiler::vis::shard`]). `plan` shows which portals each shard flows; `shard K/N`
//! flows one shard into its file (K from the engine's array index when only N is given);
//! `status` lists the shard files missing or stale; `merge` writes the map from them exactly as
//! `sightline vis --waves W` writes it. Every step takes `sightline vis`'s flags, and must be
//! given the same input and the options that change rows (`--level`, `--waves`) as the others.

use std::path::PathBuf;

use anyhow::{Context, anyhow, bail};
use clap::Subcommand;

use sightline_compiler::dropin;
use sightline_compiler::vis::VisError;
use sightline_compiler::vis::plan::{MAX_SHARDS, Plan, PlanReport};
use sightline_compiler::vis::shard::{self, MergeSpec, ShardFiles, ShardReport, ShardState, ShardStatus};

use crate::outcome::Outcome;

/// Environment variables that hold a task's 0-based array index, in the order they are read:
/// Slurm job arrays, Kubernetes Indexed Jobs, HyperQueue.
pub const INDEX_VARIABLES: [&str; 3] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX", "HQ_TASK_ID"];

/// What `sightline vis plan|shard|merge|status` does.
pub const ABOUT: &str = "Vis one map across machines: `sightline vis plan|shard|merge|status`";

/// Arguments of `sightline vis plan|shard|merge|status` (reached as `sightline vis STEP`).
#[derive(Debug, clap::Args)]
#[command(about = ABOUT, bin_name = "sightline vis")]
pub struct Args {
    /// The step.
    #[command(subcommand)]
    pub step: Step,
}

/// The steps of a sharded vis.
#[derive(Debug, Subcommand)]
pub enum Step {
    /// Show which one-way portals each shard flows and its estimated cost (from base vis).
    Plan(PlanArgs),
    /// Flow one shard (K/N, K from 1; or N alone, K then 1 + the first of SLURM_ARRAY_TASK_ID,
    /// JOB_COMPLETION_INDEX, HQ_TASK_ID, which count from 0) into its file; rerun, the same bytes.
    Shard(ShardArgs),
    /// Write the map's PVS from every shard file, exactly as `sightline vis --waves W` would
    /// (into the .bsp, an external .vis, or NAME.vis of a .prt).
    Merge(MergeArgs),
    /// List the shard files done, missing and stale (exit 1 when any is not done).
    Status(PlanArgs),
}

/// The plan and the vis flags.
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// Shards per wave, 1 to 65536.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SHARDS)))]
    pub shards: u32,
    /// The folder of the shard files (default: `INPUT.shards` beside the input).
    #[arg(long, value_name = "DIR")]
    pub dir: Option<PathBuf>,
    /// `sightline vis`'s input and flags (`--waves W` gives the plan's waves, default 1).
    #[command(flatten)]
    pub vis: super::Args,
}

/// `vis shard`.
#[derive(Debug, clap::Args)]
pub struct ShardArgs {
    /// `K/N` (shard K of N, from 1), or `N` to take K from the engine's array index.
    #[arg(value_name = "K/N")]
    pub shard: String,
    /// The plan's wave this shard belongs to, from 1 (a wave after the first reads every shard
    /// file of the waves before it).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub wave: u32,
    /// The folder of the shard files (default: `INPUT.shards` beside the input).
    #[arg(long, value_name = "DIR")]
    pub dir: Option<PathBuf>,
    /// `sightline vis`'s input and flags (`--waves W` gives the plan's waves, default 1).
    #[command(flatten)]
    pub vis: super::Args,
}

/// `vis merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// Merge without the missing shard files: their portals keep their base vis (a looser PVS,
    /// never hiding a visible leaf); the report says how many and how much looser.
    #[arg(long)]
    pub allow_partial: bool,
    /// The plan and the vis flags.
    #[command(flatten)]
    pub plan: PlanArgs,
}

/// Run the step.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    match &args.step {
        Step::Plan(a) => plan(a),
        Step::Shard(a) => run_shard(a),
        Step::Merge(a) => {
            if a.plan.vis.vis.fast {
                bail!("{}: --fast has no flow to merge from shards", a.plan.vis.input.display());
            }
            let files = files(&a.plan)?;
            super::run_with(&a.plan.vis, Some(MergeSpec { files, allow_partial: a.allow_partial }))
        }
        Step::Status(a) => status(a),
    }
}

/// The plan `shards` × `--waves`.
fn plan_of(shards: u32, vis: &super::Args) -> anyhow::Result<Plan> {
    Ok(Plan::new(shards, vis.waves.unwrap_or(1))?)
}

fn files(a: &PlanArgs) -> anyhow::Result<ShardFiles> {
    let path = super::resolve_input(&a.vis.input);
    Ok(ShardFiles::for_input(&path, a.dir.as_deref(), plan_of(a.shards, &a.vis)?))
}

/// The input's portal file and the vis options, as `sightline vis` reads them.
fn portals(
    vis: &super::Args,
) -> anyhow::Result<(PathBuf, sightline_formats::prt::PortalFile, dropin::DropInOptions)> {
    let path = super::resolve_input(&vis.input);
    if vis.vis.fast {
        bail!("{}: --fast has no flow to split into shards", path.display());
    }
    let opts = super::drop_in_options(vis);
    let prt = dropin::portals(&path, &opts)?;
    Ok((path, prt, opts))
}

fn plan(a: &PlanArgs) -> anyhow::Result<Outcome> {
    let (path, prt, opts) = portals(&a.vis)?;
    let plan = plan_of(a.shards, &a.vis)?;
    let report = shard::plan(&prt, &opts.vis, plan).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    crate::out::report(a.vis.json, &report, || plan_text(&path.display().to_string(), &report))?;
    Ok(Outcome::Clean)
}

fn plan_text(input: &str, r: &PlanReport) -> String {
    let mut s = format!(
        "{input}: {} shards in {} waves over {} one-way portals ({} a wave); largest shard {:.2} x the mean\n",
        r.plan.shards, r.plan.waves, r.portals, r.wave_size, r.imbalance
    );
    for sh in &r.shards {
        s += &format!(
            "wave {} shard {}/{}: {} portals, estimated cost {}\n",
            sh.wave,
            sh.index,
            r.plan.shards,
            sh.portals.len(),
            sh.cost
        );
    }
    s
}

/// Shard `K` of `N` from `K/N`, or from `N` and the first array index set in the environment.
fn shard_index(spec: &str, env: impl Fn(&str) -> Option<String>) -> anyhow::Result<(u32, u32)> {
    let number = |s: &str, what: &str| -> anyhow::Result<u32> {
        s.trim().parse::<u32>().map_err(|_| anyhow!("`{spec}`: {what} `{s}` is not a whole number"))
    };
    let (k, n) = match spec.split_once('/') {
        Some((k, n)) => (number(k, "K")?, number(n, "N")?),
        None => {
            let n = number(spec, "N")?;
            let Some((var, value)) = INDEX_VARIABLES.iter().find_map(|v| env(v).map(|x| (*v, x))) else {
                bail!("`{spec}` gives no K and none of {} is set: give K/N", INDEX_VARIABLES.join(", "));
            };
            let i = value.trim().parse::<u32>().with_context(|| format!("{var}={value} is not an index"))?;
            (i.saturating_add(1), n)
        }
    };
    if !(1..=MAX_SHARDS).contains(&n) || !(1..=n).contains(&k) {
        bail!(
            "shard {k}/{n} is not in 1..={n} (of at most {MAX_SHARDS} shards); array indices count from 0 \
             (Slurm: --array=0-{})",
            n.saturating_sub(1)
        );
    }
    Ok((k, n))
}

fn run_shard(a: &ShardArgs) -> anyhow::Result<Outcome> {
    let (k, n) = shard_index(&a.shard, |v| std::env::var(v).ok())?;
    let (path, prt, opts) = portals(&a.vis)?;
    let files = ShardFiles::for_input(&path, a.dir.as_deref(), plan_of(n, &a.vis)?);
    let bars = crate::progress::Bars::batched(a.vis.json || a.vis.no_progress, 32);
    let report = shard::run_shard(&prt, &opts.vis, &files, a.wave, k, &bars).map_err(|e| match e {
        VisError::Interrupted { done, total } => anyhow!(
            "{}: stopped after {done} of {total} portals of shard {k}/{n}; nothing written, run it again",
            path.display()
        ),
        e => anyhow!("{}: {e}", path.display()),
    })?;
    drop(bars);
    crate::out::report(a.vis.json, &report, || shard_text(&report, n))?;
    Ok(Outcome::Clean)
}

fn shard_text(r: &ShardReport, n: u32) -> String {
    format!(
        "shard {}/{n} of wave {}: {} portals, {} chains, {:.3} s -> {}\n",
        r.index, r.wave, r.portals, r.chains, r.seconds, r.path
    )
}

fn status(a: &PlanArgs) -> anyhow::Result<Outcome> {
    let (path, prt, opts) = portals(&a.vis)?;
    let files = ShardFiles::for_input(&path, a.dir.as_deref(), plan_of(a.shards, &a.vis)?);
    let list = shard::status(&prt, &opts.vis, &files).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    crate::out::report(a.vis.json, &list, || status_text(&list))?;
    Ok(if list.iter().all(|s| s.state == ShardState::Done) { Outcome::Clean } else { Outcome::Finding })
}

fn status_text(list: &[ShardStatus]) -> String {
    let done = list.iter().filter(|s| s.state == ShardState::Done).count();
    let mut s = format!("{done} of {} shard files done\n", list.len());
    for st in list {
        match &st.state {
            ShardState::Done => {}
            ShardState::Missing => s += &format!("missing: {}\n", st.path),
            ShardState::Stale(why) => s += &format!("stale: {} ({why})\n", st.path),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shard_index_comes_from_k_of_n_or_the_first_array_index_set() {
        let none = |_: &str| None;
        assert_eq!(shard_index("3/8", none).expect("3/8"), (3, 8));
        let slurm = |v: &str| (v == "SLURM_ARRAY_TASK_ID").then(|| "0".to_string());
        assert_eq!(shard_index("8", slurm).expect("slurm"), (1, 8));
        let both = |v: &str| match v {
            "JOB_COMPLETION_INDEX" => Some("7".to_string()),
            "HQ_TASK_ID" => Some("2".to_string()),
            _ => None,
        };
        assert_eq!(shard_index("8", both).expect("k8s first"), (8, 8));
        for bad in ["0/8", "9/8", "8", "x/8", "1/0", "1/x"] {
            assert!(shard_index(bad, none).is_err(), "{bad}");
        }
        let past = |v: &str| (v == "HQ_TASK_ID").then(|| "8".to_string());
        assert!(shard_index("8", past).is_err(), "index 8 of 8 shards counts from 0");
    }
}
