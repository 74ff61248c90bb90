//! Tests of the portal file readers and writer.

use proptest::prelude::*;

use super::*;

const SMALL: &str = "PRT2\n3\n2\n1\n4 0 1 (0 0 0) (0 64 0) (0 64 64) (0 0 64)\n0 1 -1\n2 -1\n";

#[test]
fn reads_prt2() {
    let f = read(SMALL, "t.prt").expect("valid");
    assert_eq!(f.format, PrtFormat::Prt2);
    assert_eq!((f.num_leaves, f.num_clusters, f.portals.len()), (3, 2, 1));
    assert_eq!(f.leaf_clusters, vec![0, 0, 1]);
    assert_eq!(f.portals[0].winding.points[2], DVec3::new(0.0, 64.0, 64.0));
    assert_eq!(read(&write(&f), "t.prt").expect("round trip"), f);
}

#[test]
fn reads_prt1_am_and_exponents() {
    let text = "PRT1-AM\n2 1 3\n3 1 0 (0 0 0)(2.84e-14 1 0)(0 1 1)\n0\n1\n1\n";
    let f = read(text, "a.prt").expect("valid");
    assert_eq!(f.format, PrtFormat::Prt1Am);
    assert_eq!(f.leaf_clusters, vec![0, 1, 1]);
    assert_eq!(f.portals[0].winding.points[1].x, 2.84e-14);
}

/// q3map2's layout: integer or `%f` coordinates, a space before `)`, flags, solid faces.
const Q3: &str = "PRT1\n3\n2\n2\n4 0 1 0 (0 0 0 ) (0 64 0 ) (0 64 64 ) (0 0 64 ) \n\
                  3 2 1 2 (0 0 0 ) (0.500000 64 0 ) (0 64 64 ) \n\
                  3 0 (0 0 0 ) (64 0 0 ) (64 0 64 ) \n3 2 (1 0 0 ) (64 0 0 ) (64 0 64 ) \n";

#[test]
fn reads_q3map2_portals_and_drops_flags_and_solid_faces() {
    let f = read(Q3, "q3.prt").expect("valid");
    assert_eq!(f.format, PrtFormat::Q3map2);
    assert_eq!((f.num_leaves, f.num_clusters, f.portals.len()), (3, 3, 2));
    assert_eq!(f.leaf_clusters, [0, 1, 2]);
    assert_eq!(f.portals[1].leaves, [2, 1]);
    assert_eq!(f.portals[1].winding.points[1], DVec3::new(0.5, 64.0, 0.0));
    assert_eq!(PrtFormat::of_text(Q3), Some(PrtFormat::Q3map2));
    assert_eq!(PrtFormat::of_text("PRT1\n3\n0\n0\n"), Some(PrtFormat::Q3map2), "no portals");
    assert_eq!(PrtFormat::of_text("PRT1\n2\n0\n1\n3 1 (0 0 0) (1 0 0) (0 1 0)"), Some(PrtFormat::Q3map2));
    assert_eq!(PrtFormat::of_text("PRT1\n2\n0\n"), Some(PrtFormat::Prt1));
    assert_eq!(PrtFormat::of_text("PRT1\n2\n1\n3 0 1 (0 0 0)"), Some(PrtFormat::Prt1));
    let back = read(&write(&f), "q3.prt").expect("round trip");
    assert_eq!(back, f);
    assert!(write(&f).starts_with("PRT1\n3\n2\n0\n4 0 1 0 ("));
    // A solid face naming a cluster out of range, and one with a bad point count.
    let e = read(&Q3.replace("3 2 (1 0 0 )", "3 3 (1 0 0 )"), "q3.prt").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::OutOfRange { value: 3, .. }) && e.line == 8, "{e}");
    let e = read(&Q3.replace("3 0 (0 0 0 )", "2 0 (0 0 0 )"), "q3.prt").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::BadPointCount(2)), "{e}");
    let e = read(&Q3.replace("\n2\n4 0", "\n900000\n4 0"), "q3.prt").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::CountTooLarge { what: "solid face", .. }), "{e}");
    let e = read(&Q3.replace("1 2 (0 0 0 ) (0.5", "1 x (0 0 0 ) (0.5"), "q3.prt").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::NotANumber { expected: "portal flags", .. }), "{e}");
    let e = read(&Q3[..Q3.len() - 10], "q3.prt").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::UnexpectedEof(_)), "{e}");
}

#[test]
fn crlf_reads_like_lf() {
    let crlf = SMALL.replace('\n', "\r\n");
    assert_eq!(read(&crlf, "w.prt"), read(SMALL, "w.prt"));
    assert_eq!(PrtFormat::of_text(&crlf), Some(PrtFormat::Prt2));
    assert_eq!(PrtFormat::of_text("\r\n  PRT1\r\n1\r\n0\r\n"), Some(PrtFormat::Prt1));
    assert_eq!(PrtFormat::of_text("PRT1-AM\r\n"), Some(PrtFormat::Prt1Am));
    assert_eq!(PrtFormat::of_text("PRT3\n"), None);
    assert_eq!(PrtFormat::of_text(""), None);
}

#[test]
fn bytes_that_are_not_utf8_are_located_errors() {
    assert_eq!(read_bytes(SMALL.as_bytes(), "b.prt"), read(SMALL, "b.prt"));
    let e = read_bytes(b"PRT1\n2\n1\n3 0 1 (0 0 0) (1 \xff 0) (0 1 0)\n", "b.prt").unwrap_err();
    assert_eq!((e.line, e.col), (4, 18));
    assert!(matches!(e.kind, PrtErrorKind::NotANumber { .. }), "{e}");
    let e = read_bytes(b"SLVL\x01\0\0\0\xff", "level.slvl").unwrap_err();
    assert!(matches!(e.kind, PrtErrorKind::BadHeader(_)), "{e}");
}

#[test]
fn a_missing_token_is_located_at_the_end_of_the_text() {
    let e = err("PRT1\n2\n1\n3 0 1 (0 0 0) (1 0 0)\n\n");
    assert!(matches!(e.kind, PrtErrorKind::UnexpectedEof(_)), "{e}");
    assert_eq!((e.line, e.col), (6, 1));
}

#[test]
fn unicode_whitespace_separates_and_columns_count_characters() {
    // An em space and a no-break space separate tokens as ASCII spaces do.
    let spaced = SMALL.replacen(' ', "\u{2003}", 3).replacen(' ', "\u{a0}", 2);
    assert_eq!(read(&spaced, "w.prt"), read(SMALL, "w.prt"));
    // Columns count characters, not bytes: `é` is two bytes, one column.
    let e = err("PRT1\n2\n1\n3 0 1 (0 0 0) (é 0 0) (0 1 0)\n");
    assert_eq!((e.line, e.col), (4, 16));
    let e = err("PRT1\n2\n1\n3 0 1 (0\u{2003}0\u{2003}0) (x 0 0) (0 1 0)\n");
    assert_eq!((e.line, e.col), (4, 16));
}

/// A name that is not UTF-8 is a name like any other (it once gave no candidate at all).
#[cfg(unix)]
#[test]
fn the_portal_file_beside_a_bsp_whose_name_is_not_utf8() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let path = |b: &[u8]| PathBuf::from(OsStr::from_bytes(b));
    assert_eq!(beside_bsp(&path(b"maps/a\xff.bsp")), [path(b"maps/a\xff.prt")]);
    assert_eq!(
        beside_bsp(&path(b"\xfe/a\xff.VIS.bsp")),
        [path(b"\xfe/a\xff.VIS.prt"), path(b"\xfe/a\xff.prt")]
    );
    assert!(beside_bsp(&path(b"a\xff.slvl")).is_empty());
}

#[test]
fn the_portal_file_beside_a_bsp() {
    let dir = Path::new("maps");
    assert_eq!(beside_bsp(&dir.join("e1m1.bsp")), [dir.join("e1m1.prt")]);
    assert_eq!(beside_bsp(&dir.join("e1m1.vis.bsp")), [dir.join("e1m1.vis.prt"), dir.join("e1m1.prt")]);
    assert_eq!(beside_bsp(Path::new("E1M1.VIS.BSP")), [PathBuf::from("E1M1.VIS.prt"), "E1M1.prt".into()]);
    assert_eq!(beside_bsp(Path::new("a.b.bsp")), [PathBuf::from("a.b.prt")]);
    assert!(beside_bsp(Path::new("e1m1.slvl")).is_empty());
    assert!(beside_bsp(Path::new(".bsp")).is_empty());
    assert_eq!(beside_bsp(Path::new(".vis.bsp")), [PathBuf::from(".vis.prt")]);
    let tmp = std::env::temp_dir().join(format!("sightline-prt-beside-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let bsp = tmp.join("m.vis.bsp");
    assert_eq!(find_beside_bsp(&bsp), None);
    std::fs::write(tmp.join("m.prt"), SMALL).expect("write");
    assert_eq!(find_beside_bsp(&bsp), Some(tmp.join("m.prt")));
    std::fs::write(tmp.join("m.vis.prt"), SMALL).expect("write");
    assert_eq!(find_beside_bsp(&bsp), Some(tmp.join("m.vis.prt")));
    std::fs::remove_dir_all(&tmp).expect("clean up");
}

fn err(text: &str) -> PrtError {
    read(text, "bad.prt").expect_err("must fail")
}

#[test]
fn rejects_bad_input_with_location() {
    let e = err("PRT1\n2\n1\n3 0 2 (0 0 0) (1 0 0) (0 1 0)\n");
    assert_eq!((e.line, e.col), (4, 5));
    assert!(matches!(e.kind, PrtErrorKind::OutOfRange { value: 2, .. }));
    assert_eq!(e.to_string(), "bad.prt:4:5: leaf 2 out of range (there are 2)");
    assert!(matches!(
        err("PRT1\n2\n1\n2 0 1 (0 0 0) (1 0 0)          \n").kind,
        PrtErrorKind::BadPointCount(2)
    ));
    assert!(matches!(
        err("PRT1\n2\n1\n65 0 1 (0 0 0)                \n").kind,
        PrtErrorKind::BadPointCount(65)
    ));
    assert!(matches!(err("PRT1\n2\n1\n3 0 1 (0 0 0) (inf 0 0) (0 1 0)\n").kind, PrtErrorKind::NonFinite(_)));
    assert!(matches!(err("PRT1\n2\n1\n3 0 1 (0 0 0) (NaN 0 0) (0 1 0)\n").kind, PrtErrorKind::NonFinite(_)));
    assert!(matches!(err("PRT3\n").kind, PrtErrorKind::BadHeader(_)));
    assert!(matches!(err("PRT1\n2\n4000000000\n").kind, PrtErrorKind::CountTooLarge { .. }));
    assert!(matches!(err("PRT1\n2\n99999999\n").kind, PrtErrorKind::CountTooLarge { .. }));
    assert!(matches!(err("PRT2\n999999\n1\n0\n").kind, PrtErrorKind::CountTooLarge { .. }));
    assert!(matches!(err("PRT1\n2\n1\n3 0 1 (0 0 0) (1 0 0) (0 1 0\n").kind, PrtErrorKind::UnexpectedEof(_)));
    assert!(matches!(err("PRT1\n2\n0\nextra").kind, PrtErrorKind::Trailing(_)));
    assert!(matches!(err("PRT2\n2\n1\n0\n0 0 -1\n").kind, PrtErrorKind::LeafTwice(0)));
    assert!(matches!(err("PRT2\n2\n1\n0\n0 -1\n").kind, PrtErrorKind::LeafMissing(1)));
    assert!(matches!(err("PRT1-AM\n1\n0\n1\n1\n").kind, PrtErrorKind::OutOfRange { .. }));
}

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![(-4096i32..4096).prop_map(f64::from), -1.0e5f64..1.0e5, (-1.0e-10f64..1.0e-10),]
}

fn portal(limit: u32) -> impl Strategy<Value = PrtPortal> {
    (0..limit, 0..limit, prop::collection::vec((coord(), coord(), coord()), 3..10)).prop_map(|(a, b, pts)| {
        PrtPortal {
            leaves: [a, b],
            winding: Winding::new(pts.into_iter().map(|(x, y, z)| DVec3::new(x, y, z)).collect()),
        }
    })
}

fn file() -> impl Strategy<Value = PortalFile> {
    (1u32..20, 0usize..6).prop_flat_map(|(clusters, kind)| {
        let format = [
            PrtFormat::Prt1,
            PrtFormat::Prt2,
            PrtFormat::Prt1Am,
            PrtFormat::Q3map2,
            PrtFormat::Vhlt,
            PrtFormat::VhltFixed,
        ][kind];
        let leaves = prop::collection::vec(0..clusters, clusters as usize..clusters as usize + 10);
        (prop::collection::vec(portal(clusters), 0..12), leaves).prop_map(move |(portals, mut lc)| {
            // Every cluster owns at least one leaf; PRT1 is the identity.
            for (i, c) in lc.iter_mut().enumerate().take(clusters as usize) {
                *c = i as u32;
            }
            match format {
                PrtFormat::Prt1 | PrtFormat::Q3map2 | PrtFormat::VhltFixed => lc.truncate(clusters as usize),
                // A VHLT portal leaf holds consecutive leaves.
                PrtFormat::Vhlt => lc.sort_unstable(),
                // The writer lists PRT2 leaves cluster by cluster, so the reader's order is the
                // same.
                PrtFormat::Prt2 | PrtFormat::Prt1Am => {}
            }
            PortalFile {
                format,
                num_leaves: lc.len() as u32,
                num_clusters: clusters,
                portals,
                leaf_clusters: lc,
            }
        })
    })
}

proptest! {
    #[test]
    fn write_then_read_is_identity(f in file()) {
        let text = write(&f);
        let back = read(&text, "p.prt").map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(back, f);
    }
}
