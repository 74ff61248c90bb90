//! `func_viscluster` on generated maps (rooms with pillars and steps): the leaves whose box centre
//! lies inside an entity's brushes, computed here from the level's leaf bounds, are exactly that
//! entity's cluster (the first entity in map order wins an overlap; one cluster for several
//! brushes); no other cluster changes; the world's tree, leaves and faces are the same as without
//! it; the PVS has no misses and only grows; it never seals a leak; one holding no open leaf
//! changes nothing at all; one over a whole detail map leaves one cluster; the compile's
//! report and `--json` count each entity's leaves; and a brush of one whose planes do not close
//! is refused at its line.

use sightline_compiler::{CompileError, CompileOptions, Compiled, NoProgress, Source, compile};
use sightline_formats::{Contents, Level};
use sightline_tests::mapgen::{IBox, MapGenParams, generate, layout};
use sightline_validate::pvs::{BitMatrix, level_pvs};
use sightline_validate::{Options, OracleChoice, validate};

const PARAMS: [MapGenParams; 2] = [
    MapGenParams { rooms_x: 1, rooms_y: 1, storeys: 1, seed: 5 },
    MapGenParams { rooms_x: 2, rooms_y: 2, storeys: 1, seed: 17 },
];

/// A brush over the box `lo..hi`, its planes facing out.
fn brush(lo: [f64; 3], hi: [f64; 3], texture: &str) -> String {
    let mut out = String::new();
    sightline_tests::mapgen::write_box_at(&mut out, lo, hi, texture);
    out
}

/// A `func_viscluster` entity over the boxes.
fn viscluster(boxes: &[([f64; 3], [f64; 3])]) -> String {
    let mut out = String::from("{\n\"classname\" \"func_viscluster\"\n");
    for (lo, hi) in boxes {
        out.push_str(&brush(*lo, *hi, "trigger"));
    }
    out.push_str("}\n");
    out
}

/// [`generate`]'s map with a `func_group` of 3 × 3 floor-to-ceiling pillars in the first and the
/// last room, so the volumes cut through many leaves.
fn pillared(params: &MapGenParams) -> String {
    let l = layout(params);
    let mut out = generate(params);
    out.push_str("{\n\"classname\" \"func_group\"\n");
    for room in [l.rooms[0], l.rooms[l.rooms.len() - 1]] {
        let at =
            |axis: usize, k: i64| (room.lo[axis] + (k + 1) * (room.hi[axis] - room.lo[axis]) / 4) / 8 * 8;
        for i in 0..3 {
            for j in 0..3 {
                let (x, y) = (at(0, i), at(1, j));
                let lo = [x - 16, y - 16, room.lo[2]].map(|c| c as f64);
                let hi = [x + 16, y + 16, room.hi[2]].map(|c| c as f64);
                out.push_str(&brush(lo, hi, "wall"));
            }
        }
    }
    out.push_str("}\n");
    out
}

fn compile_text(text: &str) -> Result<Compiled, CompileError> {
    let map = sightline_formats::map::parse(text, "vc.map").expect("generated maps parse");
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    compile(&Source::Map { map, file: "vc.map".to_string() }, &opts, &NoProgress)
}

/// The volumes used on a layout: part of the first room (offsets off the 8-unit grid, so no leaf
/// centre lies on a face), then an entity overlapping it with a second brush in the last room.
fn volumes(rooms: &[IBox]) -> Vec<Vec<([f64; 3], [f64; 3])>> {
    let f = |v: [i64; 3]| v.map(|c| c as f64);
    let (first, last) = (rooms[0], rooms[rooms.len() - 1]);
    let (lo, hi) = (f(first.lo), f(first.hi));
    let mid = (lo[0] + hi[0]) / 2.0 + 3.0;
    let a = ([lo[0] - 21.0, lo[1] - 21.0, lo[2] - 21.0], [mid, hi[1] + 21.0, hi[2] + 21.0]);
    let b1 = ([mid - 61.0, lo[1] + 5.0, lo[2] - 21.0], [hi[0] - 13.0, hi[1] - 37.0, hi[2] + 21.0]);
    let (llo, lhi) = (f(last.lo), f(last.hi));
    let b2 = ([llo[0] + 29.0, llo[1] + 29.0, llo[2] - 21.0], [lhi[0] - 29.0, lhi[1] - 45.0, lhi[2] + 21.0]);
    vec![vec![a], vec![b1, b2]]
}

/// Per open leaf, the first volume whose box holds its bounds' centre.
fn expected_groups(level: &Level, volumes: &[Vec<([f64; 3], [f64; 3])>]) -> Vec<Option<usize>> {
    level
        .leaves
        .iter()
        .map(|l| {
            if l.contents == Contents::Solid || l.cluster < 0 {
                return None;
            }
            let c: [f64; 3] = std::array::from_fn(|i| (l.mins[i] as f64 + l.maxs[i] as f64) / 2.0);
            volumes
                .iter()
                .position(|boxes| boxes.iter().any(|(lo, hi)| (0..3).all(|i| lo[i] <= c[i] && c[i] <= hi[i])))
        })
        .collect()
}

fn leaf_visible(level: &Level, pvs: &BitMatrix, a: usize, b: usize) -> bool {
    let (ca, cb) = (level.leaves[a].cluster, level.leaves[b].cluster);
    ca >= 0 && cb >= 0 && pvs.get(ca as usize, cb as usize)
}

#[test]
fn a_viscluster_merges_exactly_the_leaves_inside_and_the_pvs_stays_conservative() {
    for params in PARAMS {
        let plain = pillared(&params);
        let vols = volumes(&layout(&params).rooms);
        let text = format!("{plain}{}", vols.iter().map(|v| viscluster(v)).collect::<String>());
        let without = compile_text(&plain).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        let with = compile_text(&text).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        let (lw, lo) = (&with.level, &without.level);

        // The world is untouched: same planes, nodes, faces, leaves but for their clusters.
        assert_eq!(lw.planes, lo.planes, "{params:?}");
        assert_eq!(lw.nodes, lo.nodes, "{params:?}");
        assert_eq!(lw.faces, lo.faces, "{params:?}");
        assert_eq!(lw.entities, lo.entities, "the entity is the compiler's own");
        assert_eq!(lw.leaves.len(), lo.leaves.len());
        for (a, b) in lw.leaves.iter().zip(&lo.leaves) {
            assert_eq!(
                (a.contents, a.mins, a.maxs, a.first_face),
                (b.contents, b.mins, b.maxs, b.first_face)
            );
            assert_eq!(a.cluster < 0, b.cluster < 0);
        }

        // Merged set: exactly the leaves whose centre lies inside, one cluster per entity.
        let expected = expected_groups(lw, &vols);
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); vols.len()];
        for (leaf, g) in expected.iter().enumerate() {
            if let Some(g) = g {
                members[*g].push(leaf);
            }
        }
        assert!(members.iter().all(|m| m.len() > 1), "{params:?}: each volume holds several leaves");
        let counts: Vec<usize> = with.stats.visclusters.iter().map(|v| v.leaves).collect();
        assert_eq!(counts, members.iter().map(Vec::len).collect::<Vec<_>>(), "{params:?}");
        let mut cluster_size = vec![0usize; lw.num_clusters as usize];
        for l in lw.leaves.iter().filter(|l| l.cluster >= 0) {
            cluster_size[l.cluster as usize] += 1;
        }
        for (leaf, l) in lw.leaves.iter().enumerate().filter(|(_, l)| l.cluster >= 0) {
            let size = cluster_size[l.cluster as usize];
            match expected[leaf] {
                Some(g) => {
                    assert_eq!(l.cluster, lw.leaves[members[g][0]].cluster, "{params:?}: leaf {leaf}");
                    assert_eq!(size, members[g].len(), "{params:?}: leaf {leaf}'s cluster is its entity's");
                }
                None => assert_eq!(size, 1, "{params:?}: leaf {leaf} outside every volume stays alone"),
            }
        }
        let merged: usize = members.iter().map(|m| m.len() - 1).sum();
        assert_eq!(lw.num_clusters as usize, lo.num_clusters as usize - merged);

        // Conservative: no misses, and every leaf pair seen before is seen now.
        let (pw, po) = (level_pvs(lw).expect("pvs"), level_pvs(lo).expect("pvs"));
        for a in 0..lw.leaves.len() {
            for b in 0..lw.leaves.len() {
                if leaf_visible(lo, &po, a, b) {
                    assert!(leaf_visible(lw, &pw, a, b), "{params:?}: leaf {a} lost sight of {b}");
                }
            }
        }
        let opts = Options { rays: 200_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(lw, &pw, &opts, &sightline_validate::NoProgress).expect("validate");
        assert_eq!(v.report.misses(), 0, "{params:?}: {}", v.report.text());
    }
}

#[test]
fn a_viscluster_holding_no_open_leaf_changes_nothing() {
    for params in PARAMS {
        let plain = generate(&params);
        let l = layout(&params);
        let far = l.brushes.iter().map(|b| b.hi[0]).max().unwrap_or(0) as f64 + 1000.0;
        // One in the void (filled solid), one inside a wall, one without brushes.
        let wall = l.brushes[0];
        let inner = |v: [i64; 3], d: f64| v.map(|c| c as f64 + d);
        let text = format!(
            "{plain}{}{}{{\n\"classname\" \"func_viscluster\"\n}}\n",
            viscluster(&[([far, far, far], [far + 64.0, far + 64.0, far + 64.0])]),
            viscluster(&[(inner(wall.lo, 1.0), inner(wall.hi, -1.0))])
        );
        let with = compile_text(&text).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        let without = compile_text(&plain).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        assert_eq!(with.level, without.level, "{params:?}");
        assert_eq!(with.prt, without.prt, "{params:?}");
        let counts: Vec<usize> = with.stats.visclusters.iter().map(|v| v.leaves).collect();
        assert_eq!(counts, [0, 0, 0]);
    }
}

#[test]
fn a_viscluster_never_seals_a_leak() {
    let params = PARAMS[1];
    let l = layout(&params);
    let mut leaks = 0;
    // Each wall left out in turn: when the map then leaks, a volume over the hole leaks alike.
    for hole in 0..l.brushes.len().min(12) {
        let mut text = String::from("{\n\"classname\" \"worldspawn\"\n");
        for (i, b) in l.brushes.iter().enumerate() {
            if i != hole {
                text.push_str(&brush(b.lo.map(|c| c as f64), b.hi.map(|c| c as f64), "wall"));
            }
        }
        text.push_str("}\n");
        let [x, y, z] = l.player_start;
        text.push_str(&format!("{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{x} {y} {z}\"\n}}\n"));
        let h = l.brushes[hole];
        let cover = viscluster(&[(h.lo.map(|c| c as f64 - 8.0), h.hi.map(|c| c as f64 + 8.0))]);
        let plain = compile_text(&text);
        let with = compile_text(&format!("{text}{cover}"));
        match (plain, with) {
            (Err(CompileError::Leak(a)), Err(CompileError::Leak(b))) => {
                assert_eq!(a, b, "hole {hole}");
                leaks += 1;
            }
            (Ok(a), Ok(b)) => assert_eq!(a.level.leaves.len(), b.level.leaves.len(), "hole {hole}"),
            (a, b) => panic!("hole {hole}: {:?} against {:?}", a.err(), b.err()),
        }
    }
    assert!(leaks > 0, "some hole leaks");
}

#[test]
fn a_viscluster_over_every_leaf_of_a_detail_map_leaves_one_cluster() {
    let path = sightline_tests::bundled_maps().join("detail_water.map");
    let plain = std::fs::read_to_string(&path).expect("bundled map");
    let without = compile_text(&plain).expect("compiles");
    assert!(without.level.num_clusters > 1 && without.stats.detail_brushes > 0);
    let all = viscluster(&[([-65536.0; 3], [65536.0; 3])]);
    let with = compile_text(&format!("{plain}{all}")).expect("compiles");
    assert_eq!(with.level.num_clusters, 1);
    assert!(with.prt.portals.is_empty(), "no portal joins two clusters");
    assert_eq!(with.stats.visclusters[0].leaves, with.stats.vis_leaves);
    assert_eq!(with.level.leaves, {
        let mut l = without.level.leaves.clone();
        l.iter_mut().filter(|l| l.cluster >= 0).for_each(|l| l.cluster = 0);
        l
    });
}

#[test]
fn the_compile_report_and_json_count_each_viscluster() {
    let params = PARAMS[1];
    let vols = volumes(&layout(&params).rooms);
    let text = format!("{}{}", pillared(&params), vols.iter().map(|v| viscluster(v)).collect::<String>());
    let expected = compile_text(&text).expect("compiles").stats.visclusters;
    let dir = std::env::temp_dir().join(format!("sightline-viscluster-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let input = dir.join("vc.map");
    std::fs::write(&input, &text).expect("write map");
    let run = |json: bool| {
        let mut cmd = std::process::Command::new(sightline_tests::sightline_binary());
        cmd.arg("compile").arg(&input).arg("-o").arg(dir.join("vc.slvl"));
        if json {
            cmd.arg("--json");
        }
        let out = cmd.output().expect("run sightline");
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let v: serde_json::Value = serde_json::from_str(run(true).trim()).expect("json");
    let listed: Vec<(u64, u64)> = v["stats"]["visclusters"]
        .as_array()
        .expect("a list")
        .iter()
        .map(|e| (e["line"].as_u64().expect("line"), e["leaves"].as_u64().expect("leaves")))
        .collect();
    assert_eq!(listed, expected.iter().map(|e| (e.line as u64, e.leaves as u64)).collect::<Vec<_>>());
    let text_report = run(false);
    for e in &expected {
        let line = format!("func_viscluster at line {}: {} vis leaves in one cluster", e.line, e.leaves);
        assert!(text_report.contains(&line), "{text_report}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_viscluster_brush_whose_planes_do_not_close_is_refused_at_its_line() {
    let plain = generate(&PARAMS[0]);
    // A box brush without its top side: an unbounded region, not a volume.
    let boxed = brush([0.0, 0.0, 0.0], [64.0, 64.0, 64.0], "trigger");
    let open: String =
        boxed.lines().filter(|l| !l.starts_with("( 0 0 64 )")).map(|l| format!("{l}\n")).collect();
    assert_eq!(open.lines().count(), boxed.lines().count() - 1, "the top side was dropped");
    let text = format!("{plain}{{\n\"classname\" \"func_viscluster\"\n{open}}}\n");
    let line = plain.lines().count() + 3;
    match compile_text(&text) {
        Err(e @ CompileError::BadBrush { .. }) => {
            let message = e.to_string();
            assert!(message.contains("do not close"), "{message}");
            assert!(
                message.contains(&format!(":{line}")) || message.contains(&format!("line {line}")),
                "{message}"
            );
        }
        other => panic!("an unbounded func_viscluster brush must be refused, got {other:?}"),
    }
}
