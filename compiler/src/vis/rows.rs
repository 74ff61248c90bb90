//! Cluster rows from portal rows, made symmetric (`M ∧ Mᵀ`).

use sightline_formats::bits;
use sightline_formats::prt::PortalFile;

use super::stats::{VisResult, VisStats};
use super::{graph, parallel};

/// Below this many words of rows (the one-way portals' rows of `words` words and the cluster
/// rows), the phases that turn rows into cluster rows run on one thread: there they take tens of
/// microseconds, less than starting a helper thread for them (on the generated 4 × 4 × 2 rooms,
/// two threads spent 0.18 ms on them against 0.10 ms on one).
pub const ROWS_SERIAL_WORDS: usize = 1 << 18;

/// The threads for the cluster-row phases of a run of `prt` with `words`-word portal rows on
/// `threads` threads (see [`ROWS_SERIAL_WORDS`]); the result is the same on any.
pub(super) fn rows_threads(prt: &PortalFile, words: usize, threads: usize) -> usize {
    let nc = prt.num_clusters as usize;
    let size =
        (2 * prt.portals.len()).saturating_mul(words).saturating_add(nc.saturating_mul(bits::words(nc)));
    if size < ROWS_SERIAL_WORDS { 1 } else { threads }
}

/// Cluster rows from portal rows: a cluster sees itself, every cluster its portals lead to, and
/// every cluster a portal it owns sees; then `M ∧ Mᵀ`.
pub(super) fn cluster_rows(
    prt: &PortalFile,
    g: &graph::Graph,
    portal_vis: &[u64],
    words: usize,
    threads: usize,
) -> VisResult {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let mut rows = vec![0u64; nc * cw];
    if cw > 0 {
        parallel::each_row(
            threads,
            &mut rows,
            cw,
            || vec![0u64; words],
            |pv, c, row| {
                pv.fill(0);
                for &q in &g.cluster_portals[c] {
                    let q = q as usize;
                    for (a, b) in pv.iter_mut().zip(&portal_vis[q * words..(q + 1) * words]) {
                        *a |= b;
                    }
                    bits::set(pv, q);
                }
                for q in bits::ones(pv) {
                    bits::set(row, g.portals[q].leaf as usize);
                }
                bits::set(row, c);
            },
        );
    }
    symmetric_result(prt, rows, threads)
}

/// The result of cluster rows (`bits::words(clusters)` words per cluster) made symmetric: `M ∧ Mᵀ`.
pub(super) fn symmetric_result(prt: &PortalFile, mut rows: Vec<u64>, threads: usize) -> VisResult {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let snapshot = rows.clone();
    if cw > 0 {
        parallel::each_row(threads, &mut rows, cw, Vec::new, |ones, a, row| {
            ones.clear();
            ones.extend(bits::ones(row));
            for &b in ones.iter() {
                if !bits::get(&snapshot[b * cw..(b + 1) * cw], a) {
                    bits::clear(row, b);
                }
            }
        });
    }
    let mut cluster_leaves = vec![Vec::new(); nc];
    for (leaf, &c) in prt.leaf_clusters.iter().enumerate() {
        cluster_leaves[c as usize].push(leaf as u32);
    }
    VisResult {
        num_leaves: prt.num_leaves as usize,
        leaf_clusters: prt.leaf_clusters.clone(),
        cluster_leaves,
        words: cw,
        rows,
        stats: VisStats::default(),
    }
}

/// The leaves visible per leaf, on average, in the result cluster rows `rows` give once made
/// symmetric ([`symmetric_result`]), counted without building it: the same number as that
/// result's [`VisResult::average_visible`].
pub(super) fn symmetric_average(prt: &PortalFile, rows: &[u64], threads: usize) -> f64 {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let mut size = vec![0u64; nc];
    for &c in &prt.leaf_clusters {
        size[c as usize] += 1;
    }
    // Per cluster `a`, its leaves times the leaves of every cluster `b` it sees that sees it.
    let mut seen = vec![0u64; nc];
    if cw > 0 {
        parallel::each_row(
            threads,
            &mut seen,
            1,
            || (),
            |(), a, out| {
                let both = bits::ones(&rows[a * cw..(a + 1) * cw])
                    .filter(|&b| bits::get(&rows[b * cw..(b + 1) * cw], a));
                out[0] = size[a] * both.map(|b| size[b]).sum::<u64>();
            },
        );
    }
    seen.iter().sum::<u64>() as f64 / prt.num_leaves.max(1) as f64
}
