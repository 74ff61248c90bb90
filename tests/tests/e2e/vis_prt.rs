//! The `.prt` reader on the reference compiler's portal files: every file parses, its counts are
//! the ones `../shared/reference/anchors.md` lists, and writing it back reads back identically.

use sightline_formats::prt::{self, PrtFormat};

/// (map, format, vis leaves, clusters, portals) from the anchors table.
const ANCHORS: [(&str, PrtFormat, u32, u32, usize); 12] = [
    ("dm1", PrtFormat::Prt2, 415, 410, 983),
    ("dm2", PrtFormat::Prt2, 968, 926, 1764),
    ("dm3", PrtFormat::Prt2, 729, 706, 1726),
    ("start", PrtFormat::Prt2, 1244, 1204, 3115),
    ("e1m1", PrtFormat::Prt2, 1344, 1167, 3062),
    ("e1m2", PrtFormat::Prt2, 1413, 1285, 3547),
    ("e1m3", PrtFormat::Prt2, 1155, 1093, 2935),
    ("lqdm1", PrtFormat::Prt2, 1096, 253, 562),
    ("lq_e0m1", PrtFormat::Prt2, 853, 572, 1336),
    ("lq_e1m1", PrtFormat::Prt2, 3669, 1292, 3636),
    ("dm2_nodetail", PrtFormat::Prt1, 969, 969, 1847),
    ("e1m1_nodetail", PrtFormat::Prt1, 1343, 1343, 3567),
];

#[test]
fn reference_portal_files_parse_with_anchor_counts_and_round_trip() {
    let Some(maps) = sightline_tests::shared_maps() else { return };
    for (name, format, leaves, clusters, portals) in ANCHORS {
        let path = maps.join("ericw").join(format!("{name}.prt"));
        let Ok(text) = std::fs::read_to_string(&path) else {
            eprintln!("note: {} missing; skipped", path.display());
            continue;
        };
        let f = prt::read(&text, &path.display().to_string()).unwrap();
        assert_eq!(
            (f.format, f.num_leaves, f.num_clusters, f.portals.len()),
            (format, leaves, clusters, portals),
            "{name}"
        );
        assert_eq!(f.leaf_clusters.len(), leaves as usize);
        assert!(
            f.portals.iter().all(|p| p.winding.points.len() >= 3 && p.leaves.iter().all(|&c| c < clusters))
        );
        let back = prt::read(&prt::write(&f), name).unwrap();
        assert_eq!(back, f, "{name}: write then read");
    }
}

#[test]
fn truncated_and_corrupted_files_fail_with_a_location() {
    let Some(maps) = sightline_tests::shared_maps() else { return };
    let Ok(text) = std::fs::read_to_string(maps.join("ericw/dm1.prt")) else { return };
    let cut = &text[..text.len() / 2];
    let e = prt::read(cut, "dm1.prt").unwrap_err();
    assert!(e.line > 1 && e.to_string().starts_with("dm1.prt:"), "{e}");
    let bad = text.replacen("(968 1256 220)", "(968 1256 nan)", 1);
    let e = prt::read(&bad, "dm1.prt").unwrap_err();
    assert!(matches!(e.kind, prt::PrtErrorKind::NonFinite(_)), "{e}");
    assert_eq!((e.line, e.col), (5, 18), "{e}");
}

/// With stderr not a terminal (an editor's compile console, a log), a long vis prints plain
/// progress lines, a line per tenth with the time elapsed and left, and a last line per phase.
#[test]
fn a_long_vis_prints_plain_progress_lines_when_stderr_is_not_a_terminal() {
    let Some(src) = sightline_tests::shared_map("ericw/e1m1.prt") else { return };
    let dir = std::env::temp_dir().join(format!("sightline-plain-progress-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let prt = dir.join("e1m1.prt");
    std::fs::copy(&src, &prt).unwrap();
    // One wave and one thread: a flow of several seconds, past the lines' quiet start.
    let out = std::process::Command::new(sightline_tests::sightline_binary())
        .args(["vis", "--threads", "1", "--waves", "1"])
        .arg(&prt)
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("vis flow: ")).collect();
    assert!(lines.iter().any(|l| l.contains("% (") && l.contains("elapsed, about")), "{stderr}");
    assert!(lines.last().is_some_and(|l| l.starts_with("vis flow: done (")), "{stderr}");
    let percents: Vec<u32> =
        lines.iter().filter_map(|l| l.strip_prefix("vis flow: ")?.split('%').next()?.parse().ok()).collect();
    assert!(percents.windows(2).all(|w| w[0] < w[1]), "each tenth once, in order: {percents:?}");
}
