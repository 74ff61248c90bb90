//! `vis` as ericw-tools' vis is called: its command line (a base name, single-dash flags
//! anywhere), `-noambient*` and `.texinfo.json`, `-farplane`.

use std::path::Path;

use crate::support::{
    code, copy_map, pvs_rows, read_bsp, run, run_in, s, shared_map, stderr, stdout_json, temp_dir,
};

fn bit(row: &[u8], k: usize) -> bool {
    row[k / 8] & (1 << (k % 8)) != 0
}

#[test]
fn vis_takes_an_ericw_command_line_base_name_and_single_dash_flags_anywhere() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let ours = copy_map(&dm1, "ericw-long", "dm1");
    let long = ours.join("dm1.bsp");
    run(&["vis", "--threads", "2", "--fast", s(&long)]);
    let expected = std::fs::read(&long).expect("vised .bsp");
    assert_ne!(expected, std::fs::read(&dm1).expect("original"), "vis wrote visdata");

    // A base name, options before it; then options after it, with harmless ones mixed in.
    let lines: [&[&str]; 3] = [
        &["vis", "-threads", "2", "-fast", "dm1"],
        &["vis", "dm1", "-fast", "-threads", "2", "-nopercent", "-v", "-nolog", "-noprogress", "-nostate"],
        &["vis", "-verbose", "-lowpriority", "0", "-Threads", "2", "dm1.bsp", "-FAST"],
    ];
    for (i, line) in lines.iter().enumerate() {
        let dir = copy_map(&dm1, &format!("ericw-short-{i}"), "dm1");
        let o = run_in(&dir, &[&line[..], &["--json"]].concat());
        let j = stdout_json(&o);
        assert!(j["input"].as_str().expect("input").ends_with("dm1.bsp"), "{line:?} resolved {j}");
        assert_eq!(
            (j["vis"]["fast"].as_bool(), j["vis"]["threads"].as_u64()),
            (Some(true), Some(2)),
            "{line:?}"
        );
        let got = std::fs::read(dir.join("dm1.bsp")).expect("vised .bsp");
        assert!(got == expected, "{line:?} writes the same bytes as --threads 2 --fast");
    }
}

#[test]
fn vis_rejects_unknown_single_dash_options_naming_them() {
    let dir = temp_dir("ericw-bad");
    let bsp = dir.join("x.bsp");
    for (args, named) in [
        (vec!["vis", "-bogus", s(&bsp)], "-bogus"),
        (vec!["vis", s(&bsp), "-threads", "2", "-noambientwind"], "-noambientwind"),
        (vec!["vis", s(&bsp), "-threads"], "-threads"),
        (vec!["vis", s(&bsp), "-farplane", "-5"], "-5"),
    ] {
        let o = run(&args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(named), "{args:?} names {named}: {}", stderr(&o));
        assert!(o.stdout.is_empty());
    }
    // Sightline's own flags are untouched: a `--` flag it does not know is clap's error.
    let o = run(&["vis", "--bogus", s(&bsp)]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--bogus"));
}

#[test]
fn vis_noambient_zeroes_every_leaf_and_texinfo_json_silences_flagged_faces() {
    // LibreQuake's lqdm1 (dm1 as compiled here has no texture names, so no sounds).
    if let Some(lq) = shared_map("ericw/lqdm1.bsp") {
        let plain = copy_map(&lq, "ambient-plain", "lqdm1");
        run_in(&plain, &["vis", "-threads", "2", "-fast", "lqdm1"]);
        let levels = |dir: &Path| {
            read_bsp(&dir.join("lqdm1.bsp")).leaves.iter().map(|l| l.ambient).collect::<Vec<_>>()
        };
        assert!(levels(&plain).iter().any(|a| a.iter().any(|&v| v > 0)), "lqdm1 has ambient sounds");

        let none = copy_map(&lq, "ambient-none", "lqdm1");
        let o = run_in(&none, &["vis", "-threads", "2", "-fast", "-noambient", "lqdm1", "--json"]);
        assert_eq!(stdout_json(&o)["ambient_off"], serde_json::json!(["water", "sky", "slime", "lava"]));
        assert!(levels(&none).iter().all(|a| *a == [0; 4]), "every leaf's ambient levels are 0");

        let sky = copy_map(&lq, "ambient-sky", "lqdm1");
        run_in(&sky, &["vis", "-threads", "2", "-fast", "-noambientsky", "lqdm1"]);
        for (a, b) in levels(&plain).iter().zip(levels(&sky)) {
            assert_eq!((b[1], [b[0], b[2], b[3]]), (0, [a[0], a[2], a[3]]), "only the sky channel changes");
        }
    }

    // ericw-tools' test map: the sky of one room is a func_group with "_noambient" "1", which its
    // qbsp writes to NAME.texinfo.json. Read beside the .bsp, it silences that room.
    let Some(map) = shared_map("ericw-testmaps/q1_vis_noambient_func_group.standin.bsp") else { return };
    let dir = copy_map(&map, "ambient-json", "m");
    let o = run_in(&dir, &["vis", "-threads", "2", "m", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["noambient_texinfos"], 1, "{j}");
    assert!(j["texinfo_json"].as_str().expect("texinfo_json").ends_with("m.texinfo.json"));
    let with_json: Vec<[u8; 4]> = read_bsp(&dir.join("m.bsp")).leaves.iter().map(|l| l.ambient).collect();
    let ericw = read_bsp(&map.with_extension("ericw.bsp"));
    assert_eq!(with_json, ericw.leaves.iter().map(|l| l.ambient).collect::<Vec<_>>(), "as ericw-tools' vis");

    std::fs::remove_file(dir.join("m.texinfo.json")).expect("remove");
    std::fs::copy(&map, dir.join("m.bsp")).expect("fresh copy");
    run_in(&dir, &["vis", "-threads", "2", "m"]);
    let without: Vec<[u8; 4]> = read_bsp(&dir.join("m.bsp")).leaves.iter().map(|l| l.ambient).collect();
    assert!(
        without.iter().zip(&with_json).any(|(a, b)| a[1] == 255 && b[1] == 0),
        "without the side file the func_group's sky sounds"
    );

    std::fs::write(dir.join("m.texinfo.json"), "{\"4\": {\"noambient\": 1}}").expect("write");
    let o = run(&["vis", s(&dir.join("m"))]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.texinfo.json"), "the bad side file is named: {}", stderr(&o));
}

#[test]
fn vis_farplane_hides_only_pairs_farther_than_it() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let full = copy_map(&dm1, "farplane-off", "dm1");
    run_in(&full, &["vis", "-threads", "2", "dm1"]);
    let far = copy_map(&dm1, "farplane-256", "dm1");
    let o = run_in(&far, &["vis", "-threads", "2", "-farplane", "256", "dm1", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["farplane"], 256.0);
    let (a, b) = (read_bsp(&full.join("dm1.bsp")), read_bsp(&far.join("dm1.bsp")));
    let (rows_a, rows_b) = (pvs_rows(&a), pvs_rows(&b));
    let n = a.visleafs();
    // Distance between the stored bounds of vis leaves i and k (BSP leaves i + 1, k + 1).
    let gap = |i: usize, k: usize| {
        let (p, q) = (&b.leaves[i + 1], &b.leaves[k + 1]);
        (0..3)
            .map(|x| f64::from((p.mins[x] - q.maxs[x]).max(q.mins[x] - p.maxs[x]).max(0.0)).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (mut seen_a, mut seen_b, mut hidden) = (0, 0, 0);
    for i in 0..n {
        assert!(bit(&rows_b[i], i), "leaf {i} still sees itself");
        for k in 0..n {
            let (va, vb) = (bit(&rows_a[i], k), bit(&rows_b[i], k));
            assert!(!vb || va, "the far plane only hides: {i} -> {k}");
            assert_eq!(vb, bit(&rows_b[k], i), "symmetric: {i} <-> {k}");
            if va && !vb {
                hidden += 1;
                assert!(gap(i, k) > 256.0, "{i} -> {k} hidden at {} units", gap(i, k));
            }
            seen_a += usize::from(va);
            seen_b += usize::from(vb);
        }
    }
    assert!(seen_b <= seen_a && hidden > 0, "dm1 has leaves more than 256 units apart that see each other");
    assert_eq!(j["vis"]["visible_pairs"], seen_b as u64, "the report counts the culled matrix");
    eprintln!("far plane 256 on dm1: {seen_a} -> {seen_b} visible leaf pairs");

    // Without a .bsp there are no leaf bounds: an error, not a guess.
    let o = run(&["vis", s(&far.join("dm1.prt")), "--farplane", "256"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("dm1.prt"), "{}", stderr(&o));
}
