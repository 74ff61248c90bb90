//! `sightline trace`'s correctness gate on real levels: the picture ray-traced against only the
//! eye cluster's PVS set equals the whole scene's, pixel for pixel (up to ties at shared edges);
//! clearing PVS bits the view needs makes them differ, and the gate names the pixel, the face and
//! the clusters.

use glam::DVec3;
use sightline_validate::bsp::BspTree;
use sightline_validate::load;
use sightline_validate::pvs::level_pvs;
use sightline_validate::trace::cells::CellCache;
use sightline_validate::trace::scene::LevelScene;
use sightline_validate::trace::{Camera, trace_camera};

/// Vised levels of every family the shared maps hold.
const LEVELS: [&str; 5] = [
    "ericw/e1m1.vis.bsp",
    "ericw/dm2.vis.bsp",
    "q2/e1m1.ericw.t1.bsp",
    "hl/start.sdhlt.vis.bsp",
    "ericw/start.vis.bsp",
];

/// Small pictures keep the test fast.
const W: u32 = 64;
const H: u32 = 48;

/// `n` random poses (the runtime's `poses`, as `sightline trace --poses`) as trace cameras.
fn poses(path: &std::path::Path, n: usize) -> Vec<Camera> {
    let world = sightline_runtime::load::load_path(path).unwrap_or_else(|e| panic!("{e}"));
    sightline_runtime::poses::random_cameras(&world, 7, n)
        .iter()
        .map(|c| Camera {
            eye: c.position.as_dvec3(),
            yaw: f64::from(c.yaw),
            pitch: f64::from(c.pitch),
            fov: 90.0,
            width: W,
            height: H,
        })
        .collect()
}

#[test]
fn pvs_set_pictures_equal_whole_scene_pictures_on_real_levels() {
    for rel in LEVELS {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
        let tree = BspTree::new(&level).unwrap();
        let pvs = level_pvs(&level).unwrap();
        let scene = LevelScene::new(&tree).unwrap();
        let mut cache = CellCache::default();
        let (mut traced, mut smaller, mut hits) = (0, 0, 0);
        for cam in poses(&path, 12) {
            // A pose the runtime puts in an open leaf may sit on a boundary the independent tree
            // calls solid; those are skipped, not traced.
            let Ok(t) = trace_camera(&scene, &pvs, &mut cache, &cam) else { continue };
            traced += 1;
            assert!(t.gate.passed(), "{rel}: eye cluster {}: {:?}", t.eye_cluster, t.gate.listed);
            assert_eq!(t.gate.same + t.gate.ties, (W * H) as usize, "{rel}");
            assert!(
                t.gate.ties * 20 < t.gate.pixels,
                "{rel}: ties are rare ({} of {})",
                t.gate.ties,
                t.gate.pixels
            );
            smaller += usize::from(t.set.triangles.len() < scene.triangles().len());
            hits += t.full.hits.iter().filter(|h| h.is_some()).count();
        }
        assert!(traced >= 8, "{rel}: only {traced} of 12 poses traced");
        assert!(smaller >= traced / 2, "{rel}: the PVS set is smaller than the world for most poses");
        assert!(hits > traced * (W * H) as usize / 2, "{rel}: rays hit the world");
    }
}

#[test]
fn clearing_pvs_bits_a_view_needs_makes_the_gate_fail_and_name_the_face() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let tree = BspTree::new(&level).unwrap();
    let mut pvs = level_pvs(&level).unwrap();
    let scene = LevelScene::new(&tree).unwrap();
    // The start of E1M1, looking down the first corridor.
    let cam = Camera {
        eye: DVec3::new(480.0, -352.0, 110.0),
        yaw: 90.0,
        pitch: 0.0,
        fov: 90.0,
        width: W,
        height: H,
    };
    let good = trace_camera(&scene, &pvs, &mut CellCache::default(), &cam).unwrap();
    assert!(good.gate.passed());
    // The farthest face seen that no leaf of the eye cluster lists: clear every bit that lets the
    // eye cluster see it.
    let (far, _) = good
        .full
        .hits
        .iter()
        .flatten()
        .filter(|h| !scene.face_clusters(h.face).contains(&good.eye_cluster))
        .map(|h| (h.face, h.t))
        .fold(None, |best: Option<(u32, f32)>, (f, t)| match best {
            Some((_, bt)) if bt >= t => best,
            _ => Some((f, t)),
        })
        .expect("the view shows a face outside the eye cluster");
    let clusters = scene.face_clusters(far);
    for &c in &clusters {
        pvs.clear(good.eye_cluster as usize, c as usize);
    }
    let bad = trace_camera(&scene, &pvs, &mut CellCache::default(), &cam).unwrap();
    assert!(!bad.gate.passed());
    let shown = good.full.hits.iter().flatten().filter(|h| h.face == far).count();
    assert!(bad.gate.mismatches + bad.gate.grazes >= shown, "every pixel of the hidden face differs");
    assert!(bad.gate.mismatches > bad.gate.grazes, "most are inside the face, not on its outline");
    assert!(!bad.gate.listed.is_empty());
    let m = bad.gate.listed.iter().find(|m| m.full.face == far).expect("the hidden face is named");
    assert_eq!(m.face_clusters, clusters);
    let text = m.to_string();
    assert!(
        text.contains(&format!("pixel ({}, {})", m.x, m.y)) && text.contains(&format!("face {far}")),
        "{text}"
    );
    for m in &bad.gate.listed {
        let cl = scene.face_clusters(m.full.face);
        assert!(
            cl.iter().all(|c| !pvs.get(good.eye_cluster as usize, *c as usize)),
            "named faces are hidden ones"
        );
    }
}

#[test]
fn trace_command_writes_the_picture_and_reports_both_modes_and_culling_in_json() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let dir = std::env::temp_dir().join(format!("sightline-trace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("view.png");
    let out = std::process::Command::new(sightline_tests::sightline_binary())
        .args(["trace", "--poses", "3", "--size", "48x32", "--raycast-spacing", "4", "--json", "-o"])
        .arg(&png)
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["passed"], true);
    assert_eq!(v["poses"].as_array().map(Vec::len), Some(3));
    for p in v["poses"].as_array().unwrap() {
        assert!(
            p["full_mrays_per_s"].as_f64().unwrap() > 0.0 && p["pvs_mrays_per_s"].as_f64().unwrap() > 0.0
        );
        assert!(p["set_triangles"].as_u64().unwrap() <= v["scene_triangles"].as_u64().unwrap());
        assert_eq!(p["mismatches"], 0);
        // The runtime's PVS walk draws every face the trace sees; the ray-cast culling may not.
        assert_eq!(p["culling"]["pvs_missed_pixels"], 0, "{p}");
        assert!(p["culling"]["raycast_faces"].as_u64() <= p["culling"]["pvs_faces"].as_u64());
    }
    for i in 0..3 {
        let f = dir.join(format!("view-{i}.png"));
        assert!(std::fs::metadata(&f).is_ok_and(|m| m.len() > 100), "{} written", f.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn runtime_pvs_walk_draws_every_face_the_trace_sees_on_real_levels() {
    for rel in LEVELS {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        let out = std::process::Command::new(sightline_tests::sightline_binary())
            .args([
                "trace",
                "--poses",
                "6",
                "--seed",
                "3",
                "--size",
                "64x48",
                "--raycast-spacing",
                "8",
                "--json",
            ])
            .arg(&path)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{rel}: {}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let poses = v["poses"].as_array().unwrap();
        assert!(poses.len() >= 4, "{rel}: {} of 6 poses traced", poses.len());
        for p in poses {
            assert_eq!(p["culling"]["pvs_missed_pixels"], 0, "{rel}: {p}");
        }
    }
}

#[test]
fn shadows_change_the_picture_and_light_both_modes_alike() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let dir = std::env::temp_dir().join(format!("sightline-trace-shadows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let run = |shadows: bool| {
        let png = dir.join(format!("view-{shadows}.png"));
        let mut cmd = std::process::Command::new(sightline_tests::sightline_binary());
        cmd.args(["trace", "--poses", "3", "--seed", "5", "--size", "64x48", "--json", "-o"])
            .arg(&png)
            .arg(&path);
        if shadows {
            cmd.arg("--shadows");
        }
        let out = cmd.output().unwrap();
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let pictures: Vec<Vec<u8>> =
            (0..3).map(|i| std::fs::read(dir.join(format!("view-{shadows}-{i}.png"))).unwrap()).collect();
        (v, pictures)
    };
    let (plain, flat) = run(false);
    let (lit, shaded) = run(true);
    let mut rays = 0;
    for (i, (p, q)) in
        plain["poses"].as_array().unwrap().iter().zip(lit["poses"].as_array().unwrap()).enumerate()
    {
        assert!(p.get("shadows").is_none());
        let s = &q["shadows"];
        // The PVS mode tries only the lights of the hit point's cluster's PVS, and lights every
        // pixel whose triangle both modes hit exactly as the full mode does.
        assert_eq!(s["differ"], 0, "pose {i}: {s}");
        rays += s["full_rays"].as_u64().unwrap();
        assert_eq!(p["eye"], q["eye"]);
        assert_ne!(flat[i], shaded[i], "pose {i}: the lit picture is another picture");
    }
    assert!(rays > 0, "E1M1's lights reach what the poses see");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn light_lists_hold_the_lights_a_clusters_pvs_names_and_cull_most() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let tree = BspTree::new(&level).unwrap();
    let pvs = level_pvs(&level).unwrap();
    let scene = LevelScene::new(&tree).unwrap();
    let lights = sightline_validate::trace::shadow::lights(&scene, &level.entities).unwrap();
    assert!(lights.len() > 20, "E1M1 has its lights: {}", lights.len());
    assert!(lights.iter().all(|l| l.value > 0.0));
    let mut lists = sightline_validate::trace::shadow::LightLists::default();
    let mut culled = 0;
    for c in 0..pvs.len() as u32 {
        let list = lists.get(&lights, &pvs, c);
        for (l, light) in lights.iter().enumerate() {
            let listed = list.binary_search(&(l as u32)).is_ok();
            let seen = light.cluster.is_some_and(|lc| pvs.get(c as usize, lc as usize));
            assert_eq!(listed, seen, "cluster {c}, light {l}");
        }
        culled += usize::from(list.len() * 2 < lights.len());
    }
    assert!(culled * 2 > pvs.len(), "most clusters see fewer than half the lights");
}
