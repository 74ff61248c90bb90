//! Unit tests of [`super::Flow`]: depth limit, explored frames, the beam-cull trial, seeding.

use glam::DVec3;
use sightline_formats::geom::Winding;
use sightline_formats::prt::{PortalFile, PrtPortal};

use super::*;
use crate::vis::base;

/// A straight corridor of `n` leaves along +x; line `i` joins leaves `i` and `i + 1`, so
/// one-way portal `2i` leads forward from leaf `i`.
fn corridor(n: u32) -> PortalFile {
    let portals = (0..n - 1)
        .map(|i| {
            let x = 64.0 * f64::from(i + 1);
            let pts = [(0.0, 0.0), (64.0, 0.0), (64.0, 64.0), (0.0, 64.0)].map(|(y, z)| DVec3::new(x, y, z));
            PrtPortal { leaves: [i, i + 1], winding: Winding::new(pts.to_vec()) }
        })
        .collect();
    PortalFile::prt1(n, portals)
}

#[test]
fn a_chain_longer_than_max_depth_stops_there_keeping_everything_it_might_see() {
    let n = 3 * MAX_FLOW_DEPTH as u32;
    let g = Graph::new(&corridor(n));
    let words = bits::words(g.portals.len());
    let mut might = base::mightsee(&g, words, 1, &|| {}).rows;
    // `Flow::run` reads rows kept in consistent pairs.
    crate::vis::symmetry::tighten_all(&mut might, words, g.portals.len());
    let seeds = Seeds::new(g.portals.len(), g.num_clusters());
    for seeding in [false, true] {
        let mut flow = Flow::new(g.portals.len(), g.num_clusters(), 4, seeding);
        let mut out = vec![0u64; words];
        flow.run(&g, &might, &seeds, 0, BEAM_TRIAL, &mut out);
        // Every portal ahead is visible, though the flow stopped at MAX_FLOW_DEPTH frames.
        assert_eq!(out, might[..words], "seeding {seeding}");
        assert_eq!(bits::count(&out), u64::from(n - 2));
        assert_eq!(flow.frames.len(), MAX_FLOW_DEPTH + 1);
        assert_eq!(flow.chains, MAX_FLOW_DEPTH as u64 + 1);
    }
}

#[test]
fn frames_covered_by_explored_ones_are_skipped_and_rows_only_get_tighter() {
    let prt = crate::vis::tests::grid(30, 24, 7);
    let g = Graph::new(&prt);
    let words = bits::words(g.portals.len());
    let mut might = base::mightsee(&g, words, 1, &|| {}).rows;
    // `Flow::run` reads rows kept in consistent pairs.
    crate::vis::symmetry::tighten_all(&mut might, words, g.portals.len());
    let seeds = Seeds::new(g.portals.len(), g.num_clusters());
    // The grid's flows are short: every frame that went deeper is kept.
    let flow = |keep_chains| Flow { keep_chains, ..Flow::new(g.portals.len(), g.num_clusters(), 4, false) };
    let (mut keeping, mut not) = (flow(2), flow(u64::MAX));
    let (mut a, mut b) = (vec![0u64; words], vec![0u64; words]);
    for base in 0..g.portals.len() {
        keeping.run(&g, &might, &seeds, base, BEAM_TRIAL, &mut a);
        not.run(&g, &might, &seeds, base, BEAM_TRIAL, &mut b);
        // A covered frame's lines are those of the frame covering it, which found all they reach.
        assert!(a.iter().zip(&b).all(|(x, y)| x & !y == 0), "portal {base}: a portal only the store found");
    }
    assert!(keeping.chains < not.chains, "{} chains against {}", keeping.chains, not.chains);
}

/// Starting from the seeds, whether most clusters (every portal covered, then the rest
/// uncovered) or a few (each seeded cluster's portals covered), gives the rows marking each
/// seeded cluster seen gives, whatever the rows held before (random seed rows of about 6 % and
/// 75 % of the clusters, with stray bits past the clusters, on grids whose cluster and portal
/// counts are not multiples of 64).
#[test]
fn seeding_marks_what_seeing_each_seeded_cluster_marks() {
    let mut rng = sightline_job::rng::SplitMix64::new(25);
    for (x, y) in [(30, 24), (7, 5), (9, 8)] {
        let g = Graph::new(&crate::vis::tests::grid(x, y, 3));
        let (n, nc) = (g.portals.len(), g.num_clusters());
        let cw = bits::words(nc);
        for dense in [false, true] {
            for _ in 0..20 {
                let mut row = || {
                    (0..cw)
                        .map(|_| match dense {
                            true => rng.next_u64() | rng.next_u64(),
                            false => rng.next_u64() & rng.next_u64() & rng.next_u64() & rng.next_u64(),
                        })
                        .collect::<Vec<u64>>()
                };
                let (through, of_cluster) = (row(), row());
                let (mut seen, mut vis) = (vec![0u64; cw], vec![0u64; bits::words(n)]);
                for c in (0..nc).filter(|&c| bits::get(&through, c) || bits::get(&of_cluster, c)) {
                    see(&mut seen, &mut vis, &g, c as u32);
                }
                let (mut seeded, mut seeded_vis) = (vec![!0u64; cw], vec![!0u64; bits::words(n)]);
                see_seeds(&mut seeded, &mut seeded_vis, &g, &through, &of_cluster);
                assert_eq!(seeded, seen, "{x} x {y}, dense {dense}");
                assert_eq!(seeded_vis, vis, "{x} x {y}, dense {dense}");
            }
        }
    }
}

#[test]
fn the_trial_shortens_after_a_run_of_quiet_flows_and_a_drop_restores_it() {
    let mut quiet = 0;
    for k in 0..QUIET_FLOWS {
        assert_eq!(trial_after(quiet), BEAM_TRIAL, "after {k} quiet flows");
        quiet = quiet_after(quiet, false);
    }
    assert_eq!(trial_after(quiet), QUIET_TRIAL);
    assert_eq!(trial_after(quiet_after(quiet, false)), QUIET_TRIAL);
    assert_eq!(trial_after(quiet_after(quiet, true)), BEAM_TRIAL);
    assert_eq!(quiet_after(usize::MAX, false), usize::MAX);
}

#[test]
fn a_flow_whose_culls_drop_nothing_stops_culling_with_the_same_result() {
    // Along a straight corridor every portal ahead is visible, so no cull drops one.
    let g = Graph::new(&corridor(48));
    let words = bits::words(g.portals.len());
    let mut might = base::mightsee(&g, words, 1, &|| {}).rows;
    // `Flow::run` reads rows kept in consistent pairs.
    crate::vis::symmetry::tighten_all(&mut might, words, g.portals.len());
    let seeds = Seeds::new(g.portals.len(), g.num_clusters());
    let mut rows = Vec::new();
    for trial in [QUIET_TRIAL, BEAM_TRIAL, u32::MAX] {
        let mut flow = Flow::new(g.portals.len(), g.num_clusters(), 4, false);
        let mut out = vec![0u64; words];
        flow.run(&g, &might, &seeds, 0, trial, &mut out);
        assert!(!flow.dropped(), "nothing to drop in a straight corridor");
        assert_eq!(flow.culls, trial.min(45), "trial {trial}: one cull per frame from 1 to 45");
        rows.push(out);
    }
    assert!(rows.iter().all(|r| *r == rows[0]));
    assert_eq!(bits::count(&rows[0]), 46);
}

/// Whether anything new lies beyond a target comes out the same from the target's own row and
/// from the reversed rows of the frame's few uncovered portals, also after `might` narrowed and
/// `vis` grew since they were listed: random rows kept in consistent pairs, frames with few and
/// with many uncovered portals, a row length that is not a multiple of 64.
#[test]
fn a_target_leads_on_alike_by_its_row_and_by_the_uncovered_portals_reversed_rows() {
    let mut rng = sightline_job::rng::SplitMix64::new(26);
    let n = 2 * 611;
    let words = bits::words(n);
    let (mut few, mut many, mut leads) = (0, 0, 0);
    for round in 0..40 {
        let sparse = round % 2 == 0;
        let bit_row = |rng: &mut sightline_job::rng::SplitMix64, sparse: bool| -> Vec<u64> {
            (0..words)
                .map(|w| {
                    let x = match sparse {
                        true => rng.next_u64() & rng.next_u64() & rng.next_u64() & rng.next_u64(),
                        false => rng.next_u64() | rng.next_u64(),
                    };
                    x & bits::valid_mask(w, n)
                })
                .collect()
        };
        // Rows in consistent pairs: `s` in row `r` with `r ^ 1` in row `s ^ 1`, about 0.25 % full, so
        // that a target leads on about as often as not.
        let mut test = vec![0u64; n * words];
        for _ in 0..n * n / 800 {
            let (r, s) = (rng.below(n), rng.below(n));
            bits::set(&mut test[r * words..(r + 1) * words], s);
            bits::set(&mut test[(s ^ 1) * words..((s ^ 1) + 1) * words], r ^ 1);
        }
        let (lo, hi) = (rng.below(2), words - rng.below(2));
        let mut frame = Frame { might: bit_row(&mut rng, sparse), lo, hi, ..Frame::default() };
        for w in (0..lo).chain(hi..words) {
            frame.might[w] = 0;
        }
        let mut vis = bit_row(&mut rng, sparse);
        frame.open = (lo..hi).filter(|&w| frame.might[w] & !vis[w] != 0).collect();
        frame.list_uncovered(&vis);
        if frame.uncovered.is_empty() {
            many += 1;
        } else {
            few += 1;
        }
        // After the listing, `might` only narrows and `vis` only grows.
        for _ in 0..3 {
            let (a, b) = (rng.below(n), rng.below(n));
            bits::clear(&mut frame.might, a);
            bits::set(&mut vis, b);
        }
        for pi in 0..n {
            let trow = &test[pi * words..(pi + 1) * words];
            let want = (lo..hi).any(|w| frame.might[w] & trow[w] & !vis[w] != 0);
            assert_eq!(frame.leads_on(&test, pi, &vis), want, "round {round}, target {pi}");
            leads += usize::from(want);
        }
    }
    assert!(few > 0 && many > 0, "{few} frames listed their uncovered portals, {many} did not");
    assert!(leads > 40 * n / 5 && leads < 40 * n * 4 / 5, "{leads} of {} targets led on", 40 * n);
}
