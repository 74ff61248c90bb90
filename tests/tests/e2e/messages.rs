//! What the real binary ([`sightline_tests::sightline_binary`]) says when a mapper gives it the
//! wrong file or a file without what a command needs: the message names the file and the command
//! or option that does what was meant.

use std::path::PathBuf;
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-messages-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn sightline(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(sightline_tests::sightline_binary()).args(args).output().expect("run sightline")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn compiling_a_compiled_map_of_any_family_suggests_vis() {
    let dir = temp_dir("compiled");
    // Each family's first bytes, then zeros: the family is known from them alone.
    let mut heads: Vec<(Vec<u8>, &str)> =
        sightline_formats::bsp::BspVersion::ALL.into_iter().map(|v| (v.magic().to_vec(), v.name())).collect();
    heads.push((b"IBSP\x26\0\0\0".to_vec(), "Quake 2"));
    heads.push((b"IBSP\x2e\0\0\0".to_vec(), "Quake 3"));
    for (i, (head, named)) in heads.iter().enumerate() {
        let path = dir.join(format!("level{i}.bsp"));
        let mut bytes = head.clone();
        bytes.resize(4096, 0);
        std::fs::write(&path, &bytes).expect("write");
        let o = sightline(&[
            "compile".as_ref(),
            path.as_os_str(),
            "-o".as_ref(),
            dir.join("out.slvl").as_os_str(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{named}: {err}");
        let expected = format!("{} is a compiled map", path.display());
        assert!(err.contains(&expected) && err.contains(named), "{named}: {err}");
        assert!(err.contains(&format!("`sightline vis {}`", path.display())), "{named}: {err}");
        assert!(!dir.join("out.slvl").exists(), "{named}: nothing written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bsp_without_its_portal_file_suggests_portals_from_bsp() {
    let Some(src) = sightline_tests::shared_map("ericw/e1m1.bsp") else { return };
    let dir = temp_dir("noprt");
    let path = dir.join("e1m1.bsp");
    std::fs::copy(&src, &path).expect("copy");
    for extra in [&[][..], &["--external-vis"][..]] {
        let mut args: Vec<&std::ffi::OsStr> = vec!["vis".as_ref(), path.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let o = sightline(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains("e1m1.prt"), "{extra:?}: names the portal file looked for: {err}");
        assert!(
            err.contains(&format!("sightline vis --portals-from-bsp {}", path.display())),
            "{extra:?}: suggests the rebuild: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_compile_report_says_what_the_filled_leaves_are() {
    let dir = temp_dir("filled");
    let out = dir.join("room.slvl");
    let map = sightline_tests::bundled_maps().join("room.map");
    let o = sightline(&[
        "compile".as_ref(),
        map.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--no-vis".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("  vis leaves"))
        .unwrap_or_else(|| panic!("a filled count: {stdout}"));
    assert!(line.contains("outside leaves filled solid "), "labelled: {line}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_base_name_lists_the_paths_tried() {
    let dir = temp_dir("missing");
    let base = dir.join("e1m1");
    let o = sightline(&["vis".as_ref(), base.as_os_str()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let listed = format!("looked for {} and {}.bsp", base.display(), base.display());
    assert!(err.contains(&listed), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_view_counts_red_pixels_only_when_checked_against_the_pvs() {
    let dir = temp_dir("render");
    let level = dir.join("room.slvl");
    let map = sightline_tests::bundled_maps().join("room.map");
    let o = sightline(&["compile".as_ref(), map.as_os_str(), "-o".as_ref(), level.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let png = dir.join("view.png");
    for pvs in [false, true] {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "render".as_ref(),
            level.as_os_str(),
            "--view".as_ref(),
            "128,128,48".as_ref(),
            "--size".as_ref(),
            "32x24".as_ref(),
            "-o".as_ref(),
            png.as_os_str(),
        ];
        if pvs {
            args.push("--pvs".as_ref());
        }
        let o = sightline(&args);
        assert_eq!(o.status.code(), Some(0), "--pvs {pvs}: {}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("leaves shown"), "--pvs {pvs}: {stdout}");
        assert_eq!(stdout.contains("red pixels"), pvs, "--pvs {pvs}: {stdout}");
        assert!(!stdout.contains("unchecked"), "--pvs {pvs}: {stdout}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_pvs_matrix_of_another_size_than_asked_says_why() {
    let dir = temp_dir("matrix");
    let level = dir.join("room.slvl");
    let map = sightline_tests::bundled_maps().join("room.map");
    let o = sightline(&["compile".as_ref(), map.as_os_str(), "-o".as_ref(), level.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let png = dir.join("matrix.png");
    let mut noted = 0;
    for size in ["512x512", "500x500", "7x7", "640x480", "1x1"] {
        let o = sightline(&[
            "render".as_ref(),
            level.as_os_str(),
            "--pvs-matrix".as_ref(),
            "--size".as_ref(),
            size.as_ref(),
            "-o".as_ref(),
            png.as_os_str(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{size}: {}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        let wrote = stdout.lines().find(|l| l.starts_with("wrote ")).expect("a wrote line");
        let differs = !wrote.ends_with(&format!("({size})"));
        let note = stdout.lines().find(|l| l.starts_with("note: the PVS matrix"));
        assert_eq!(note.is_some(), differs, "{size}: {stdout}");
        if let Some(note) = note {
            assert!(note.contains(&format!("not the {size} asked")) && note.contains("clusters"), "{note}");
            noted += 1;
        }
    }
    assert!(noted > 0, "640x480 is never square");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validate_ends_with_a_pass_or_fail_line_matching_its_exit() {
    let dir = temp_dir("validate");
    let level = dir.join("room.slvl");
    let map = sightline_tests::bundled_maps().join("room.map");
    let o = sightline(&["compile".as_ref(), map.as_os_str(), "-o".as_ref(), level.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = sightline(&["validate".as_ref(), level.as_os_str(), "--rays".as_ref(), "20000".as_ref()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let last = stdout.lines().last().unwrap_or_default();
    match o.status.code() {
        Some(0) => assert!(last.starts_with("PASS: ") && last.contains(" rays)"), "{stdout}"),
        Some(1) => assert!(last.starts_with("FAIL: ") && last.contains(" misses"), "{stdout}"),
        _ => panic!("{}", stderr(&o)),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_portal_backend_says_why_it_cannot_run() {
    let Some(src) = sightline_tests::shared_map("ericw/e1m1.bsp") else { return };
    let dir = temp_dir("portal");
    let path = dir.join("e1m1.bsp");
    std::fs::copy(&src, &path).expect("copy");
    let o = sightline(&["bench".as_ref(), path.as_os_str(), "--backend".as_ref(), "portal".as_ref()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no portals") && err.contains(".prt beside it"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
