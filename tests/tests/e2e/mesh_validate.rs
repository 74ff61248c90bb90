//! Triangle soups compile to a conservative PVS: random scenes of boxes, broken in the ways real
//! meshes are (open boxes, flipped, duplicated and coplanar triangles, slivers, stray triangles,
//! bent quads), are compiled with vis and ray-validated against both oracles; no sampled pair may
//! be missing from the PVS. Every case is drawn from `SplitMix64::keyed(SEED, case, 0)`.

use glam::DVec3;
use sightline_compiler::mesh::Mesh;
use sightline_compiler::{CompileOptions, Compiled, NoProgress, Source, compile};
use sightline_formats::Contents;
use sightline_job::rng::SplitMix64;
use sightline_validate::bsp::BspTree;
use sightline_validate::pvs::level_pvs;
use sightline_validate::{Options, OracleChoice, validate};

const SEED: u64 = 0x5eed_3e54;
/// Random scenes.
const CASES: u64 = 48;
/// Ray budget per oracle and scene.
const RAYS: u64 = 60_000;

/// The twelve triangles of the box `lo..hi`, counter-clockwise seen from outside.
fn closed_box(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
    let c = |x: bool, y: bool, z: bool| {
        DVec3::new(if x { hi.x } else { lo.x }, if y { hi.y } else { lo.y }, if z { hi.z } else { lo.z })
    };
    let (f, t) = (false, true);
    let quads = [
        [c(f, f, f), c(f, t, f), c(t, t, f), c(t, f, f)], // bottom, down
        [c(f, f, t), c(t, f, t), c(t, t, t), c(f, t, t)], // top, up
        [c(f, f, f), c(f, f, t), c(f, t, t), c(f, t, f)], // x = lo, -x
        [c(t, f, f), c(t, t, f), c(t, t, t), c(t, f, t)], // x = hi, +x
        [c(f, f, f), c(t, f, f), c(t, f, t), c(f, f, t)], // y = lo, -y
        [c(f, t, f), c(f, t, t), c(t, t, t), c(t, t, f)], // y = hi, +y
    ];
    quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect()
}

fn coordinate(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    // Half the scenes on the integer grid (coplanar faces meet exactly), half anywhere.
    if rng.below(2) == 0 { rng.range_f64(lo, hi).round() } else { rng.range_f64(lo, hi) }
}

fn random_box(rng: &mut SplitMix64) -> (DVec3, DVec3) {
    let lo = DVec3::new(
        coordinate(rng, -200.0, 150.0),
        coordinate(rng, -200.0, 150.0),
        coordinate(rng, 0.0, 80.0),
    );
    let size = DVec3::new(coordinate(rng, 4.0, 96.0), coordinate(rng, 4.0, 96.0), coordinate(rng, 4.0, 96.0));
    (lo, lo + size)
}

/// Ways a mesh goes wrong, each applied with some probability.
fn damage(rng: &mut SplitMix64, tris: &mut Vec<[DVec3; 3]>) -> Vec<&'static str> {
    let mut done = Vec::new();
    let pick = |rng: &mut SplitMix64, n: usize| rng.below(n.max(1));
    if rng.below(3) == 0 {
        for _ in 0..1 + rng.below(3) {
            let i = pick(rng, tris.len());
            tris.remove(i);
        }
        done.push("open");
    }
    if rng.below(3) == 0 {
        for _ in 0..1 + rng.below(3) {
            let i = pick(rng, tris.len());
            tris[i].swap(1, 2);
        }
        done.push("flipped");
    }
    if rng.below(4) == 0 {
        let i = pick(rng, tris.len());
        let t = tris[i];
        tris.push(t);
        tris.push([t[0], t[2], t[1]]);
        done.push("duplicated");
    }
    if rng.below(4) == 0 {
        // A triangle on another one's plane, overlapping it and reaching past it.
        let i = pick(rng, tris.len());
        let [a, b, c] = tris[i];
        let grow = rng.range_f64(0.5, 1.8);
        tris.push([a, a + (b - a) * grow, a + (c - a) * grow * 0.7]);
        done.push("coplanar");
    }
    if rng.below(4) == 0 {
        // A sliver: nearly a line, across the scene.
        let a =
            DVec3::new(rng.range_f64(-250.0, 250.0), rng.range_f64(-250.0, 250.0), rng.range_f64(0.0, 120.0));
        let b = a + DVec3::new(rng.range_f64(-200.0, 200.0), rng.range_f64(-200.0, 200.0), 0.0);
        tris.push([a, b, (a + b) * 0.5 + DVec3::new(0.0, 0.0, rng.range_f64(0.02, 0.5))]);
        done.push("sliver");
    }
    if rng.below(4) == 0 {
        let c =
            DVec3::new(rng.range_f64(-250.0, 250.0), rng.range_f64(-250.0, 250.0), rng.range_f64(0.0, 120.0));
        let mut corner = || {
            c + DVec3::new(rng.range_f64(-60.0, 60.0), rng.range_f64(-60.0, 60.0), rng.range_f64(-60.0, 60.0))
        };
        tris.push([corner(), corner(), corner()]);
        done.push("stray");
    }
    if rng.below(4) == 0 {
        // Bend a quad: move one corner of one triangle a little off its plane.
        let i = pick(rng, tris.len());
        tris[i][rng.below(3)] += DVec3::new(0.0, 0.0, rng.range_f64(-2.0, 2.0));
        done.push("bent");
    }
    done
}

/// Scene `case`: a ground slab, boxes on and above it, sometimes a room around them, then damage.
fn scene(case: u64) -> (Vec<[DVec3; 3]>, Vec<&'static str>) {
    let mut rng = SplitMix64::keyed(SEED, case, 0);
    let mut tris = closed_box(DVec3::new(-256.0, -256.0, -16.0), DVec3::new(256.0, 256.0, 0.0));
    for _ in 0..1 + rng.below(5) {
        let (lo, hi) = random_box(&mut rng);
        tris.extend(closed_box(lo, hi));
    }
    if rng.below(4) == 0 {
        // A room seen from inside: its triangles face in.
        let room = closed_box(DVec3::new(-300.0, -300.0, -40.0), DVec3::new(300.0, 300.0, 200.0));
        tris.extend(room.into_iter().map(|[a, b, c]| [a, c, b]));
    }
    let done = damage(&mut rng, &mut tris);
    (tris, done)
}

fn compile_mesh(triangles: Vec<[DVec3; 3]>, name: &str) -> Compiled {
    let src = Source::Mesh { mesh: Mesh { triangles, skipped_faces: 0 }, file: name.to_string() };
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    compile(&src, &opts, &NoProgress).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn misses(out: &Compiled, rays: u64) -> (usize, String) {
    let pvs = level_pvs(&out.level).expect("pvs");
    let opts = Options { rays, oracle: OracleChoice::Both, ..Options::default() };
    let v = validate(&out.level, &pvs, &opts, &sightline_validate::NoProgress).expect("validates");
    (v.report.misses(), v.report.text())
}

#[test]
fn damaged_box_scenes_have_no_misses() {
    let mut damaged = 0;
    for case in 0..CASES {
        let (tris, done) = scene(case);
        damaged += usize::from(!done.is_empty());
        let name = format!("case {case} ({})", done.join(", "));
        let out = compile_mesh(tris, &name);
        let (misses, text) = misses(&out, RAYS);
        assert_eq!(misses, 0, "{name}: {text}\nwarnings: {:?}", out.stats.warnings);
    }
    assert!(damaged > CASES as usize / 2, "most scenes are damaged ({damaged})");
}

#[test]
fn closed_boxes_stay_solid_and_open_ones_are_opened_with_a_warning() {
    let slab = closed_box(DVec3::new(-256.0, -256.0, -16.0), DVec3::new(256.0, 256.0, 0.0));
    let cube = closed_box(DVec3::new(-32.0, -32.0, 0.0), DVec3::new(32.0, 32.0, 64.0));
    let inside = DVec3::new(0.0, 0.0, 32.0);
    let contents_at = |out: &Compiled, p: DVec3| {
        let tree = BspTree::new(&out.level).expect("tree");
        out.level.leaves[tree.leaf_at(p)].contents
    };
    let closed = compile_mesh([slab.clone(), cube.clone()].concat(), "closed");
    assert!(closed.stats.warnings.is_empty(), "{:?}", closed.stats.warnings);
    assert_eq!(contents_at(&closed, inside), Contents::Solid);
    assert_eq!(contents_at(&closed, DVec3::new(0.0, 0.0, -8.0)), Contents::Solid, "inside the slab");
    assert_ne!(contents_at(&closed, DVec3::new(100.0, 100.0, 32.0)), Contents::Solid);
    // Beyond the margin around the triangles the world is solid.
    assert_eq!(contents_at(&closed, DVec3::new(0.0, 0.0, 64.0 + 17.0)), Contents::Solid);

    // Without its top, the cube's inside is open to the sky: it must not stay solid.
    let open_top: Vec<_> =
        cube.iter().enumerate().filter(|(i, _)| !(2..4).contains(i)).map(|(_, t)| *t).collect();
    let open = compile_mesh([slab.clone(), open_top].concat(), "open.obj");
    assert_ne!(contents_at(&open, inside), Contents::Solid);
    let w = open.stats.warnings.join("\n");
    assert!(w.contains("open.obj: the mesh is not closed: 4 edges belong to one triangle only"), "{w}");
    assert!(w.contains("(-32 -32 64) to (32 32 64)"), "{w}");
    assert!(w.contains("cells behind triangles are not enclosed"), "{w}");
    assert_eq!(misses(&open, RAYS).0, 0);

    // A one-sided quad floating 4 units over the ground encloses nothing under it.
    let (a, b, c, d) = (
        DVec3::new(-100.0, -100.0, 4.0),
        DVec3::new(100.0, -100.0, 4.0),
        DVec3::new(100.0, 100.0, 4.0),
        DVec3::new(-100.0, 100.0, 4.0),
    );
    let quad = compile_mesh([slab.clone(), vec![[a, b, c], [a, c, d]]].concat(), "quad.obj");
    assert_ne!(contents_at(&quad, DVec3::new(0.0, 0.0, 2.0)), Contents::Solid);
    assert_ne!(contents_at(&quad, DVec3::new(0.0, 0.0, 6.0)), Contents::Solid);
    assert_eq!(misses(&quad, RAYS).0, 0);

    // A flipped triangle on a closed cube leaves no open edge, yet its plane no longer tells
    // inside from outside; whatever the tree makes of it, nothing may hide a visible leaf.
    let mut flipped = cube;
    flipped[7].swap(1, 2);
    let out = compile_mesh([slab, flipped].concat(), "flipped.obj");
    assert_eq!(misses(&out, RAYS).0, 0, "{:?}", out.stats.warnings);
}

#[test]
fn bundled_scene_obj_has_no_misses() {
    let path = sightline_tests::bundled_maps().join("scene.obj");
    let src = Source::read(&path).expect("reads");
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    let out = compile(&src, &opts, &NoProgress).expect("compiles");
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    let (misses, text) = misses(&out, 400_000);
    assert_eq!(misses, 0, "{text}");
}
