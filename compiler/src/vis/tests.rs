//! Unit tests of the whole vis pipeline on small synthetic portal files.

use glam::DVec3;
use sightline_formats::geom::Winding;
use sightline_formats::prt::{PortalFile, PrtFormat, PrtPortal};

use super::*;

/// A square portal on the plane `x = x0` spanning `y, z` in `[y0, y0 + s]`, facing into `into`
/// (its winding plane faces -X when `into` is the lower-x leaf).
fn square_x(x0: f64, y0: f64, z0: f64, s: f64, toward_neg: bool) -> Winding {
    let pts = vec![
        DVec3::new(x0, y0, z0),
        DVec3::new(x0, y0 + s, z0),
        DVec3::new(x0, y0 + s, z0 + s),
        DVec3::new(x0, y0, z0 + s),
    ];
    let w = Winding::new(pts);
    let n = w.plane().expect("plane").normal;
    if (n.x < 0.0) == toward_neg { w } else { w.reversed() }
}

/// Leaves 0..n in a row along +X, each 64 wide; portal i joins leaf i and i+1 at x = 64(i+1),
/// with its square offset by `offsets[i]` in y.
fn corridor(offsets: &[f64], widths: &[f64]) -> PortalFile {
    let mut x = 0.0;
    let portals = offsets
        .iter()
        .enumerate()
        .map(|(i, &o)| {
            x += widths[i];
            // The winding faces into leaves[0] = i (the -X side).
            PrtPortal { leaves: [i as u32, i as u32 + 1], winding: square_x(x, o, 0.0, 32.0, true) }
        })
        .collect::<Vec<_>>();
    let n = offsets.len() as u32 + 1;
    PortalFile {
        format: PrtFormat::Prt1,
        num_leaves: n,
        num_clusters: n,
        portals,
        leaf_clusters: (0..n).collect(),
    }
}

fn none() -> impl Fn(VisProgress) + Sync {
    |_| {}
}

#[test]
fn straight_corridor_sees_everything() {
    let prt = corridor(&[0.0; 5], &[64.0; 5]);
    let r = run(&prt, &VisOptions::default(), &none()).expect("vis");
    for a in 0..6 {
        for b in 0..6 {
            assert!(r.leaf_sees(a, b), "{a} should see {b}");
        }
    }
    assert_eq!(r.stats.visible_pairs, 36);
}

#[test]
fn zigzag_hides_far_leaves_but_fast_does_not() {
    // Openings alternate far apart in y: leaf 0 cannot see through three of them.
    let prt = corridor(&[0.0, 400.0, 0.0, 400.0], &[16.0; 4]);
    let full = run(&prt, &VisOptions::default(), &none()).expect("vis");
    let fast = run(&prt, &VisOptions { fast: true, ..VisOptions::default() }, &none()).expect("fast");
    assert!(full.leaf_sees(0, 1) && full.leaf_sees(0, 2));
    assert!(!full.leaf_sees(0, 4), "full vis must cull the far end");
    assert!(!full.leaf_sees(4, 0), "symmetric");
    assert!(fast.leaf_sees(0, 4), "base vis sees along the corridor");
    assert!(full.stats.visible_pairs < fast.stats.visible_pairs);
}

#[test]
fn thin_leaf_and_nearly_coplanar_portals_never_block_sight() {
    // Leaf 1 is 0.01 units thick; leaf 3 is 1e-3 thick and its far portal is tilted by 1e-4 rad.
    let mut prt = corridor(&[0.0, 0.0, 0.0, 0.0, 0.0], &[64.0, 0.01, 64.0, 0.001, 64.0]);
    for p in &mut prt.portals[4].winding.points {
        p.x += (p.y + p.z) * 1e-4;
    }
    for level in [0, 2, 4] {
        let r = run(&prt, &VisOptions { level, ..VisOptions::default() }, &none()).expect("vis");
        for b in 0..6 {
            assert!(r.leaf_sees(0, b), "level {level}: 0 must see {b}");
        }
    }
}

#[test]
fn deterministic_across_threads_and_resumable() {
    let offsets: Vec<f64> = (0..40).map(|i| ((i * 37) % 11) as f64 * 9.0).collect();
    let prt = corridor(&offsets, &[24.0; 40]);
    let one = run(&prt, &VisOptions { threads: 1, ..VisOptions::default() }, &none()).expect("1");
    let four = run(&prt, &VisOptions { threads: 4, ..VisOptions::default() }, &none()).expect("4");
    assert_eq!(one.rows, four.rows);
    let dir = std::env::temp_dir().join(format!("sightline-vis-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let state = dir.join("c.state");
    let opts =
        VisOptions { state: Some(state.clone()), stop_after: Some(FLOW_BATCH), ..VisOptions::default() };
    assert!(matches!(run(&prt, &opts, &none()), Err(VisError::Interrupted { .. })));
    let resumed = run(&prt, &VisOptions { stop_after: None, ..opts }, &none()).expect("resume");
    assert_eq!(resumed.stats.resumed_portals, FLOW_BATCH);
    assert_eq!(resumed.rows, one.rows);
    assert!(!state.exists(), "finished runs remove their state");
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

#[test]
fn rejects_bad_level_and_inconsistent_files() {
    let prt = corridor(&[0.0], &[64.0]);
    assert!(matches!(
        run(&prt, &VisOptions { level: 5, ..VisOptions::default() }, &none()),
        Err(VisError::Option(_))
    ));
    let mut bad = prt.clone();
    bad.leaf_clusters = vec![0, 7];
    assert!(matches!(run(&bad, &VisOptions::default(), &none()), Err(VisError::Invalid(_))));
}

#[test]
fn one_way_windings_turn_counter_clockwise_about_their_normal() {
    // The separator search relies on it (see `poly::Poly::normal`), whichever way the file's
    // windings face.
    for toward_neg in [true, false] {
        let mut prt = corridor(&[0.0, 8.0], &[64.0, 64.0]);
        for p in &mut prt.portals {
            let w = &p.winding;
            let n = w.plane().expect("plane").normal;
            if (n.x < 0.0) != toward_neg {
                p.winding = w.reversed();
            }
        }
        let g = graph::Graph::new(&prt);
        assert_eq!(g.portals.len(), 4);
        for p in &g.portals {
            let w = g.winding(p);
            let newell: DVec3 = (0..w.len()).map(|i| w[i].cross(w[(i + 1) % w.len()])).sum();
            assert!(newell.normalize().dot(p.plane.normal) > 0.999, "portal into {}", p.leaf);
        }
    }
}

#[test]
fn windings_count_as_convex_only_when_they_are() {
    let prt = corridor(&[0.0, 8.0], &[64.0, 64.0]);
    assert!(graph::Graph::new(&prt).convex);
    // A dart: the fourth point is pulled 4 units inside, past the line of two edges.
    let mut dart = prt.clone();
    dart.portals[0].winding = Winding::new(vec![
        DVec3::new(64.0, 0.0, 0.0),
        DVec3::new(64.0, 32.0, 0.0),
        DVec3::new(64.0, 32.0, 32.0),
        DVec3::new(64.0, 16.0, 4.0),
        DVec3::new(64.0, 0.0, 32.0),
    ]);
    assert!(!graph::Graph::new(&dart).convex);
    // A bent winding: one corner 0.5 units off the plane.
    let mut bent = prt;
    bent.portals[1].winding.points[2].x += 0.5;
    assert!(!graph::Graph::new(&bent).convex);
}
