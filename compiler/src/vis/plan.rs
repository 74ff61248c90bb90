//! Shard plans: which one-way portals (the work units) each shard of a run flows, in waves.
//!
//! The flow's processing order (increasing `mightsee`) is cut into `waves`
//! consecutive waves of [`wave_size`] portals (the last may be shorter, later ones empty). A
//! portal of wave `w` reads the rows and seeds of waves before `w` only, so the rows of a wave do
//! not depend on how its portals are split between shards: every split of every wave, and the
//! one-process run in batches of one wave ([`VisOptions::waves`](super::VisOptions::waves)),
//! give the same rows, bit for bit. One wave flows every portal from the base vis rows alone;
//! more waves let later portals prune by earlier ones (as the default batches do), at the price
//! of a round of shards per wave.
//!
//! Within a wave, portals go to shards by their estimated cost (the square of their `mightsee`
//! count): most expensive first, each to the shard with the least cost so far (the lowest index
//! on a tie), so expensive and cheap portals interleave and the shards' estimates stay close.
//! A shard lists its portals in that order, its most expensive first.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sightline_formats::bits;

use super::error::VisError;

/// Most shards a plan may have.
pub const MAX_SHARDS: u32 = 65_536;

/// Most waves a plan may have.
pub const MAX_WAVES: u32 = 1024;

/// How a run is split: `shards` shards in each of `waves` waves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Plan {
    /// Shards per wave, 1..=[`MAX_SHARDS`].
    pub shards: u32,
    /// Waves, 1..=[`MAX_WAVES`].
    pub waves: u32,
}

impl Plan {
    /// A plan of `shards` shards in each of `waves` waves; out of range is a
    /// [`VisError::Option`].
    pub fn new(shards: u32, waves: u32) -> Result<Self, VisError> {
        if !(1..=MAX_SHARDS).contains(&shards) {
            return Err(VisError::Option(format!("{shards} shards is out of range 1..={MAX_SHARDS}")));
        }
        if !(1..=MAX_WAVES).contains(&waves) {
            return Err(VisError::Option(format!("{waves} waves is out of range 1..={MAX_WAVES}")));
        }
        Ok(Self { shards, waves })
    }
}

/// Portals per wave for `n` one-way portals in `waves` waves (at least 1).
pub fn wave_size(n: usize, waves: u32) -> usize {
    n.div_ceil(waves.max(1) as usize).max(1)
}

/// The order portals are flowed in: increasing `mightsee` (the `n` rows of `might`, `words`
/// words each), then portal number.
pub(super) fn processing_order(might: &[u64], words: usize, n: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_cached_key(|&p| (bits::count(&might[p * words..(p + 1) * words]), p));
    order
}

/// Where the shard files of a plan live: `dir/STEM.K-of-N.shard` for a plan of one wave,
/// `dir/STEM.waveW-of-WS.K-of-N.shard` otherwise (`K`, `W` from 1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardFiles {
    /// The folder.
    pub dir: PathBuf,
    /// The file names' stem (the map's name).
    pub stem: String,
    /// The plan.
    pub plan: Plan,
}

impl ShardFiles {
    /// The shard files of `plan` for the input at `input`, in `dir` or else the folder
    /// `INPUT.shards` beside it (`e1m1.bsp.shards`).
    pub fn for_input(input: &Path, dir: Option<&Path>, plan: Plan) -> Self {
        let dir = dir.map_or_else(
            || {
                let mut d = input.as_os_str().to_owned();
                d.push(".shards");
                PathBuf::from(d)
            },
            Path::to_path_buf,
        );
        let stem = input.file_stem().map_or_else(|| "vis".to_string(), |s| s.to_string_lossy().into_owned());
        Self { dir, stem, plan }
    }

    /// The file of shard `index` of wave `wave` (both from 1).
    pub fn path(&self, wave: u32, index: u32) -> PathBuf {
        let (n, ws) = (self.plan.shards, self.plan.waves);
        let name = if ws == 1 {
            format!("{}.{index}-of-{n}.shard", self.stem)
        } else {
            format!("{}.wave{wave}-of-{ws}.{index}-of-{n}.shard", self.stem)
        };
        self.dir.join(name)
    }
}

/// A merge of shard files (what `VisOptions::merge` asks for).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MergeSpec {
    /// The files.
    pub files: ShardFiles,
    /// Merge without the missing shards: their portals keep their base-vis rows.
    pub allow_partial: bool,
}

/// A plan laid over a run's portals.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    /// The processing order.
    pub order: Vec<usize>,
    /// Positions of `order` per wave.
    pub wave_size: usize,
    /// Per wave, per shard: its portals, most expensive first.
    pub units: Vec<Vec<Vec<u32>>>,
    /// Per wave, per shard: its estimated cost.
    pub cost: Vec<Vec<u64>>,
}

impl Layout {
    /// The layout of `plan` over `n` portals whose `mightsee` rows are `might` (`words` each, as
    /// base vis left them, before any tightening).
    pub fn new(plan: Plan, might: &[u64], words: usize, n: usize) -> Self {
        let order = processing_order(might, words, n);
        let size = wave_size(n, plan.waves);
        let shards = plan.shards as usize;
        let mut units = Vec::with_capacity(plan.waves as usize);
        let mut costs = Vec::with_capacity(plan.waves as usize);
        for w in 0..plan.waves as usize {
            let range = (w * size).min(n)..((w + 1) * size).min(n);
            let mut wave: Vec<(u64, usize, usize)> = order[range.clone()]
                .iter()
                .zip(range)
                .map(|(&p, pos)| {
                    let m = bits::count(&might[p * words..(p + 1) * words]) as u64;
                    (m * m, pos, p)
                })
                .collect();
            wave.sort_by_key(|&(cost, pos, _)| (std::cmp::Reverse(cost), pos));
            let mut lists = vec![Vec::new(); shards];
            let mut load = vec![0u64; shards];
            for (cost, _, p) in wave {
                let k = (0..shards).min_by_key(|&k| (load[k], k)).unwrap_or(0);
                load[k] = load[k].saturating_add(cost);
                lists[k].push(p as u32);
            }
            units.push(lists);
            costs.push(load);
        }
        Self { order, wave_size: size, units, cost: costs }
    }

    /// Positions of the processing order in wave `w` (0-based).
    pub fn wave_range(&self, w: usize) -> std::ops::Range<usize> {
        let n = self.order.len();
        (w * self.wave_size).min(n)..((w + 1) * self.wave_size).min(n)
    }
}

/// One shard of a plan, as `sightline vis plan` shows it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ShardSummary {
    /// Its wave, from 1.
    pub wave: u32,
    /// Its index in the wave, from 1.
    pub index: u32,
    /// The one-way portals it flows, most expensive first.
    pub portals: Vec<u32>,
    /// Its estimated cost (the sum of its portals' squared `mightsee` counts).
    pub cost: u64,
}

/// A plan laid over an input: every shard's portals and estimated cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// The plan.
    pub plan: Plan,
    /// One-way portals (work units) in all.
    pub portals: usize,
    /// Portals per wave.
    pub wave_size: usize,
    /// Every shard, wave after wave.
    pub shards: Vec<ShardSummary>,
    /// The largest shard cost over the mean shard cost of each wave, the worst wave's (1 is an
    /// even split).
    pub imbalance: f64,
}

impl Layout {
    /// What `sightline vis plan` reports.
    pub fn report(&self, plan: Plan) -> PlanReport {
        let mut shards = Vec::new();
        let mut imbalance = 1.0f64;
        for (w, (lists, costs)) in self.units.iter().zip(&self.cost).enumerate() {
            let total: u64 = costs.iter().sum();
            let max = costs.iter().copied().max().unwrap_or(0);
            if total > 0 {
                imbalance = imbalance.max(max as f64 * costs.len() as f64 / total as f64);
            }
            for (k, (list, &cost)) in lists.iter().zip(costs).enumerate() {
                shards.push(ShardSummary {
                    wave: w as u32 + 1,
                    index: k as u32 + 1,
                    portals: list.clone(),
                    cost,
                });
            }
        }
        PlanReport { plan, portals: self.order.len(), wave_size: self.wave_size, shards, imbalance }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_portal_is_in_exactly_one_shard_of_its_wave_and_costs_balance() {
        // 40 portals of one word, portal p might see p % 13 + 1 others.
        let n = 40;
        let might: Vec<u64> = (0..n).map(|p| (1u64 << (p % 13 + 1)) - 1).collect();
        for (shards, waves) in [(1, 1), (3, 1), (7, 2), (16, 3), (50, 1), (2, 64)] {
            let plan = Plan::new(shards, waves).expect("plan");
            let layout = Layout::new(plan, &might, 1, n);
            assert_eq!(layout.units.len(), waves as usize);
            for w in 0..waves as usize {
                let mut got: Vec<u32> = layout.units[w].iter().flatten().copied().collect();
                got.sort_unstable();
                let mut want: Vec<u32> =
                    layout.order[layout.wave_range(w)].iter().map(|&p| p as u32).collect();
                want.sort_unstable();
                assert_eq!(got, want, "wave {w} of {shards}x{waves}");
                // Greedy by decreasing cost: no shard is ahead of another by more than the
                // largest single cost.
                let costs = &layout.cost[w];
                let (lo, hi) = (costs.iter().min().copied(), costs.iter().max().copied());
                assert!(hi.unwrap_or(0) - lo.unwrap_or(0) <= 14 * 14, "{costs:?}");
            }
        }
        assert!(
            Plan::new(0, 1).is_err() && Plan::new(1, 0).is_err() && Plan::new(MAX_SHARDS + 1, 1).is_err()
        );
    }
}
