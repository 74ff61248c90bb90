//! The VHLT/SDHLT portal file of Half-Life's `hlbsp` (see `../shared/reference/family.md` §5).
//!
//! - There is no header word: the file starts with the number of portal leaves, then the number
//!   of portals.
//! - [`PrtFormat::Vhlt`]: one line per portal leaf with the number of BSP vis leaves it holds
//!   (written before the portal lines). Portal leaf `i` holds the consecutive vis leaves after
//!   those of portal leaves `0..i`, so a portal leaf is a cluster and
//!   [`PortalFile::leaf_clusters`] is non-decreasing; `num_leaves` is the sum of the counts.
//! - [`PrtFormat::VhltFixed`]: after `hlvis` ran, "FixPrt" deletes the count lines (for the
//!   J.A.C.K. editor). Which vis leaves a portal leaf holds is then unknown; the file reads as one
//!   vis leaf per portal leaf, which is right only when the BSP has as many vis leaves (vis
//!   checks that against the `.bsp`).
//! - Portal lines are as in PRT1 (`n a b (x y z)…`, a and b portal leaves) and face the same way.
//! - Which of the two: the third line is a lone integer (a count) or the start of a portal line.

use std::fmt::Write as _;

use super::{Lexer, MAX_LEAVES, PortalFile, PrtError, PrtErrorKind, PrtFormat, Reader};

/// Which VHLT dialect `text` (starting with a number) is: [`PrtFormat::Vhlt`] when the token
/// after the two header counts stands alone on its line and is an integer, else
/// [`PrtFormat::VhltFixed`].
pub(super) fn sniff(text: &str) -> PrtFormat {
    let mut lx = Lexer::new(text);
    has_count_lines(&mut lx)
}

/// As [`sniff`], from the lexer's position (before the two counts); moves the lexer.
fn has_count_lines(lx: &mut Lexer<'_>) -> PrtFormat {
    let _ = (lx.next_token(), lx.next_token());
    let Some(third) = lx.next_token() else { return PrtFormat::VhltFixed };
    let alone = lx.next_token().is_none_or(|next| lx.text[third.start..next.start].contains('\n'));
    if alone && third.text.parse::<i64>().is_ok() { PrtFormat::Vhlt } else { PrtFormat::VhltFixed }
}

/// Reads a VHLT file with `r` at its first token.
pub(super) fn read(mut r: Reader<'_, '_>) -> Result<PortalFile, PrtError> {
    let format = has_count_lines(&mut r.lx.clone());
    let (at, num_clusters) = r.count("portal leaf")?;
    let (_, num_portals) = r.count("portal")?;
    let leaf_clusters = if format == PrtFormat::Vhlt {
        // Every count line takes at least two characters.
        let remaining = r.lx.text.len().saturating_sub(r.lx.pos);
        if num_clusters as usize > remaining / 2 {
            let kind = PrtErrorKind::CountTooLarge { what: "portal leaf", count: num_clusters.into() };
            return Err(r.err(at, kind));
        }
        let mut counts = Vec::with_capacity(num_clusters as usize);
        let mut total = 0u64;
        for _ in 0..num_clusters {
            let (tok, n) = r.integer("a leaf count")?;
            let Ok(n) = u32::try_from(n) else {
                return Err(r.at(&tok, PrtErrorKind::BadLeafCount(n)));
            };
            total += u64::from(n);
            if total > u64::from(MAX_LEAVES) {
                return Err(r.at(&tok, PrtErrorKind::CountTooLarge { what: "leaf", count: total }));
            }
            counts.push(n);
        }
        let mut of = Vec::with_capacity(total as usize);
        for (cluster, &n) in counts.iter().enumerate() {
            of.extend(std::iter::repeat_n(cluster as u32, n as usize));
        }
        of
    } else {
        if num_clusters > MAX_LEAVES {
            let kind = PrtErrorKind::CountTooLarge { what: "portal leaf", count: num_clusters.into() };
            return Err(r.err(at, kind));
        }
        (0..num_clusters).collect()
    };
    r.check_portal_count(num_portals)?;
    let portals = r.portals(num_portals, num_clusters, "cluster", false)?;
    r.end()?;
    Ok(PortalFile { format, num_leaves: leaf_clusters.len() as u32, num_clusters, portals, leaf_clusters })
}

/// Writes the lines before the portals: the two counts, and for [`PrtFormat::Vhlt`] the vis
/// leaves of each portal leaf (how many leaves name it in `leaf_clusters`, which must list each
/// portal leaf's leaves consecutively, as the reader gives them).
pub(super) fn write_head(prt: &PortalFile, s: &mut String) -> std::fmt::Result {
    write!(s, "{}\n{}\n", prt.num_clusters, prt.portals.len())?;
    if prt.format == PrtFormat::Vhlt {
        let mut counts = vec![0u32; prt.num_clusters as usize];
        for &c in &prt.leaf_clusters {
            if let Some(n) = counts.get_mut(c as usize) {
                *n += 1;
            }
        }
        for n in counts {
            writeln!(s, "{n}")?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::read;
    use super::*;

    const COUNTS: &str =
        "3\n2\n1\n2\n1\n4 0 1 (0 0 0) (0 64 0) (0 64 64) (0 0 64) \n3 1 2 (0 0 0) (8 0 0) (8 8 0) \n";
    const FIXED: &str = "3\n2\n4 0 1 (0 0 0) (0 64 0) (0 64 64) (0 0 64) \n3 1 2 (0 0 0) (8 0 0) (8 8 0) \n";

    #[test]
    fn reads_both_dialects() {
        let f = read(COUNTS, "m.prt").expect("valid");
        assert_eq!(f.format, PrtFormat::Vhlt);
        assert_eq!((f.num_leaves, f.num_clusters, f.portals.len()), (4, 3, 2));
        assert_eq!(f.leaf_clusters, [0, 1, 1, 2]);
        assert_eq!(f.portals[1].leaves, [1, 2]);
        let g = read(FIXED, "m.prt").expect("valid");
        assert_eq!(g.format, PrtFormat::VhltFixed);
        assert_eq!((g.num_leaves, g.num_clusters, g.leaf_clusters.clone()), (3, 3, vec![0, 1, 2]));
        assert_eq!(g.portals, f.portals);
        assert_eq!(PrtFormat::of_text(COUNTS), Some(PrtFormat::Vhlt));
        assert_eq!(PrtFormat::of_text(&FIXED.replace('\n', "\r\n")), Some(PrtFormat::VhltFixed));
        assert_eq!(read(&super::super::write(&f), "m.prt"), Ok(f));
        assert_eq!(read(&super::super::write(&g), "m.prt"), Ok(g));
        // A portal leaf may hold no leaf; an empty file of each shape reads.
        assert_eq!(read("2\n0\n0\n3\n", "m.prt").map(|f| f.leaf_clusters), Ok(vec![1, 1, 1]));
        assert_eq!(read("0\n0\n", "m.prt").map(|f| f.format), Ok(PrtFormat::VhltFixed));
    }

    #[test]
    fn rejects_bad_counts_with_location() {
        let err = |t: &str| read(t, "bad.prt").expect_err("must fail");
        let e = err("3\n2\n1\n-2\n1\n");
        assert_eq!((e.line, e.col, &e.kind), (4, 1, &PrtErrorKind::BadLeafCount(-2)));
        assert!(e.to_string().starts_with("bad.prt:4:1: "), "{e}");
        assert!(matches!(err("2\n0\n1\n4194304\n").kind, PrtErrorKind::CountTooLarge { what: "leaf", .. }));
        assert!(matches!(err("9999\n0\n1\n").kind, PrtErrorKind::CountTooLarge { what: "portal leaf", .. }));
        assert!(matches!(err("9999999\n0\n").kind, PrtErrorKind::CountTooLarge { what: "portal leaf", .. }));
        assert!(matches!(err("1\n99\n1\n").kind, PrtErrorKind::CountTooLarge { what: "portal", .. }));
        assert!(matches!(
            err("3\n1\n1\n2\n1\n4 0 3 (0 0 0) (0 64 0) (0 64 64) (0 0 64) \n").kind,
            PrtErrorKind::OutOfRange { value: 3, .. }
        ));
        assert!(matches!(err(&format!("{COUNTS}7\n")).kind, PrtErrorKind::Trailing(_)));
        assert!(matches!(err("2\n0\n1\n    \n").kind, PrtErrorKind::UnexpectedEof(_)));
    }
}
