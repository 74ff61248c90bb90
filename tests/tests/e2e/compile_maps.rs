//! Real maps compile sealed, and their portal graphs hold the invariants the compiler promises.

use std::collections::VecDeque;

use glam::DVec3;
use sightline_compiler::{CompileOptions, Compiled, NoProgress, Source, compile};
use sightline_formats::{Contents, Level};

fn compile_file(path: &std::path::Path) -> Compiled {
    let text = std::fs::read_to_string(path).expect("readable map");
    let name = path.display().to_string();
    let map = sightline_formats::map::parse(&text, &name).expect("map parses");
    compile(&Source::Map { map, file: name }, &CompileOptions::default(), &NoProgress)
        .expect("compiles sealed")
}

fn v(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// The leaf holding `p`; points on a plane go to the back, as the compiler places entities.
fn leaf_at(level: &Level, p: DVec3) -> usize {
    let mut c = level.models[0].head_node;
    while c >= 0 {
        let n = &level.nodes[c as usize];
        let pl = &level.planes[n.plane as usize];
        let d = v(pl.normal).dot(p) - pl.dist as f64;
        c = if d > 0.0 { n.children[0] } else { n.children[1] };
    }
    (-(c + 1)) as usize
}

/// Portal invariants: on the plane, inside both leaves' bounds, joining non-solid leaves (sky only
/// to sky); the player start is in a kept leaf; and the leaves reachable through portals from the
/// entities (the player start and, in maps with areas joined only by teleporters, the entities
/// there) are exactly the non-solid, non-sky leaves the outside fill kept.
fn check_portal_graph(level: &Level, start: DVec3, origins: &[DVec3]) {
    const EPS: f64 = 0.05;
    let mut adjacency = vec![Vec::new(); level.leaves.len()];
    for (i, p) in level.portals.iter().enumerate() {
        let plane = &level.planes[p.plane as usize];
        let first = p.first_vertex as usize;
        let pts: Vec<DVec3> =
            level.vertices[first..first + p.num_vertices as usize].iter().map(|&x| v(x)).collect();
        assert!(pts.len() >= 3, "portal {i} has {} points", pts.len());
        for &q in &pts {
            let d = v(plane.normal).dot(q) - plane.dist as f64;
            assert!(d.abs() < EPS, "portal {i} point {q} is {d} off its plane");
        }
        let sky = p.leaves.map(|l| level.leaves[l as usize].contents == Contents::Sky);
        assert_eq!(sky[0], sky[1], "portal {i} joins sky to something else");
        for &l in &p.leaves {
            let leaf = &level.leaves[l as usize];
            assert_ne!(leaf.contents, Contents::Solid, "portal {i} touches solid leaf {l}");
            let (lo, hi) = (v(leaf.mins) - DVec3::splat(EPS), v(leaf.maxs) + DVec3::splat(EPS));
            for &q in &pts {
                assert!(q.cmpge(lo).all() && q.cmple(hi).all(), "portal {i} point {q} outside leaf {l}");
            }
        }
        adjacency[p.leaves[0] as usize].push(p.leaves[1] as usize);
        adjacency[p.leaves[1] as usize].push(p.leaves[0] as usize);
    }
    let first = leaf_at(level, start);
    assert_ne!(level.leaves[first].contents, Contents::Solid, "player start in solid");
    let mut seen = vec![false; level.leaves.len()];
    let mut queue = VecDeque::new();
    for &o in origins {
        let l = leaf_at(level, o);
        if level.leaves[l].contents != Contents::Solid && !seen[l] {
            seen[l] = true;
            queue.push_back(l);
        }
    }
    assert!(seen[first]);
    while let Some(l) = queue.pop_front() {
        for &n in &adjacency[l] {
            if !seen[n] {
                seen[n] = true;
                queue.push_back(n);
            }
        }
    }
    let world_leaves = level.leaves.len() - submodel_leaves(level);
    for (i, leaf) in level.leaves.iter().take(world_leaves).enumerate() {
        // Sky is kept (it borders the world) but opaque: no portal joins it to other contents.
        assert_eq!(
            seen[i],
            leaf.contents != Contents::Solid && leaf.contents != Contents::Sky,
            "leaf {i} ({:?}) kept vs reached",
            leaf.contents
        );
    }
}

/// Leaves of submodel trees come after the world's.
fn submodel_leaves(level: &Level) -> usize {
    let mut count = 0;
    for m in level.models.iter().skip(1) {
        let mut stack = vec![m.head_node];
        while let Some(c) = stack.pop() {
            if c < 0 {
                count += 1;
            } else {
                stack.extend(level.nodes[c as usize].children);
            }
        }
    }
    count
}

fn player_start(level: &Level) -> DVec3 {
    let text = &level.entities;
    let at = text.find("info_player_start").expect("map has info_player_start");
    let block_start = text[..at].rfind('{').expect("entity start");
    let block = &text[block_start..];
    let block = &block[..block.find('}').expect("entity end")];
    let line = block.lines().find(|l| l.starts_with("\"origin\"")).expect("origin");
    let nums: Vec<f64> = line
        .split('"')
        .nth(3)
        .expect("value")
        .split_whitespace()
        .map(|t| t.parse().expect("number"))
        .collect();
    DVec3::new(nums[0], nums[1], nums[2])
}

#[test]
fn representative_real_maps_compile_sealed_with_a_sound_portal_graph() {
    let Some(dir) = sightline_tests::shared_maps() else { return };
    for name in ["id/e1m1.map", "id/dm1.map", "id/start.map", "librequake/lq_e0m1.map"] {
        let path = dir.join(name);
        if !path.exists() {
            eprintln!("note: {} absent; skipped", path.display());
            continue;
        }
        let out = compile_file(&path);
        let s = &out.stats;
        eprintln!(
            "{name}: {} brushes, {} faces, {} nodes, {} leaves, {} vis leaves, {} portals",
            s.brushes, s.faces, s.nodes, s.leaves, s.vis_leaves, s.portals
        );
        assert!(s.vis_leaves > 0 && s.portals > 0);
        if out.prt.format == sightline_formats::prt::PrtFormat::Prt1 {
            assert_eq!(out.prt.portals.len(), out.level.portals.len());
        } else {
            // PRT2 keeps only the portals between clusters.
            assert!(out.prt.portals.len() < out.level.portals.len());
            assert_eq!(out.prt.leaf_clusters.len() as u32, out.prt.num_leaves);
        }
        let text = sightline_formats::prt::write(&out.prt);
        let back = sightline_formats::prt::read(&text, name).expect("our .prt reads back");
        assert_eq!(back.portals.len(), out.prt.portals.len());
        assert_eq!(back.leaf_clusters, out.prt.leaf_clusters);
        for p in &out.prt.portals {
            assert!(p.leaves.iter().all(|&l| l < out.prt.num_leaves));
            assert!(p.winding.is_valid(0.05), "non-convex or non-planar portal winding");
        }
        let text = std::fs::read_to_string(&path).expect("map");
        let map = sightline_formats::map::parse(&text, name).expect("parses");
        let origins: Vec<DVec3> = map.entities.iter().skip(1).filter_map(|e| e.origin()).collect();
        check_portal_graph(&out.level, player_start(&out.level), &origins);
    }
}

/// Every shared map compiles sealed (no leak), including ones whose brushes meet only along an
/// edge (LibreQuake's lqdm3 has such a pinch, which must seal as it does in qbsp).
#[test]
fn every_shared_map_compiles_without_a_leak() {
    let Some(dir) = sightline_tests::shared_maps() else { return };
    let mut compiled = 0;
    for sub in ["id", "librequake"] {
        let Ok(entries) = std::fs::read_dir(dir.join(sub)) else { continue };
        let mut paths: Vec<_> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
        paths.sort();
        for path in paths.into_iter().filter(|p| p.extension().is_some_and(|e| e == "map")) {
            let out = compile_file(&path);
            assert!(out.leak.is_none(), "{} leaks", path.display());
            assert!(out.stats.vis_leaves > 0, "{} has no open leaf", path.display());
            compiled += 1;
        }
    }
    assert!(compiled >= 20, "only {compiled} shared maps found");
}
