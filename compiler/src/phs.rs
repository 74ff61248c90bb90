//! Quake 2's potentially hearable set, and the Quake 2 visibility lump built from vis rows.
//!
//! [`phs`] computes the PHS as q2tools' `CalcPHS` does: the row of cluster `c` is the union (OR)
//! of PVS(c) and the PVS rows of every cluster in PVS(c), over the whole row. (ericw-tools
//! 2.0.0-alpha11 ORs only whole `long`s of each row and loses the last bytes; this does not.)
//! [`q2_vis_lump`] compresses PVS and PHS rows into a visibility lump
//! ([`sightline_formats::bsp::q2::vis_lump`]); [`repair_phs`] recomputes only the PHS of a Quake 2
//! file already vised, keeping the compressed bytes of every PVS row.

use sightline_formats::bits;
use sightline_formats::bsp::BspError;
use sightline_formats::bsp::q2::{self, Q2Row};
use sightline_formats::rle;

/// The PHS of `n` clusters from their PVS: `pvs` holds `n` word rows of `words` words
/// ([`bits`]); the result has the same shape. Row `c` is PVS(c) OR the PVS row of every cluster
/// `j < n` set in PVS(c). Bits at or beyond `n` are neither followed nor kept.
pub fn phs(pvs: &[u64], words: usize, n: usize) -> Vec<u64> {
    let mut out = vec![0u64; n * words];
    if words == 0 {
        return out;
    }
    for (c, row) in out.chunks_exact_mut(words).enumerate() {
        let Some(own) = pvs.get(c * words..(c + 1) * words) else { break };
        row.copy_from_slice(own);
        for j in bits::ones(own).take_while(|&j| j < n) {
            if let Some(other) = pvs.get(j * words..(j + 1) * words) {
                row.iter_mut().zip(other).for_each(|(a, b)| *a |= b);
            }
        }
        for (w, word) in row.iter_mut().enumerate() {
            *word &= bits::valid_mask(w, n);
        }
    }
    out
}

/// Byte rows (`n` rows of `row_bytes` bytes, Quake's layout) as word rows of `bits::words(n)`.
pub fn words_from_bytes(rows: &[u8], n: usize) -> Vec<u64> {
    let words = bits::words(n);
    let row_bytes = bits::bytes::len(n);
    let mut out = vec![0u64; n * words];
    for c in 0..n {
        let Some(row) = rows.get(c * row_bytes..(c + 1) * row_bytes) else { break };
        for (i, &b) in row.iter().enumerate() {
            out[c * words + i / 8] |= u64::from(b) << ((i % 8) * 8);
        }
    }
    out
}

/// Compressed rows of `n` word rows of `words` words.
fn compress(rows: &[u64], words: usize, n: usize) -> Vec<Vec<u8>> {
    let mut bytes = Vec::new();
    (0..n)
        .map(|c| {
            bits::to_bytes(
                rows.get(c * words..(c + 1) * words).unwrap_or_default(),
                bits::bytes::len(n),
                &mut bytes,
            );
            let mut out = Vec::new();
            rle::encode_row(&bytes, &mut out);
            out
        })
        .collect()
}

/// The Quake 2 visibility lump of `n` clusters with PVS rows `pvs` and PHS rows `phs_rows` (word
/// rows of `words` words, the PHS from [`phs`]): both compressed, PVS rows first.
pub fn q2_vis_lump(pvs: &[u64], phs_rows: &[u64], words: usize, n: usize) -> Result<Vec<u8>, BspError> {
    q2::vis_lump(&compress(pvs, words, n), &compress(phs_rows, words, n))
}

/// What [`repair_phs`] changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct PhsRepair {
    /// Clusters.
    pub clusters: usize,
    /// PHS rows that differ from the recomputed union.
    pub rows_fixed: usize,
    /// Bits the stored PHS lacked.
    pub bits_added: u64,
    /// Bits the stored PHS had beyond the union.
    pub bits_removed: u64,
    /// Ordered visible pairs of the PVS.
    pub pvs_pairs: u64,
    /// Ordered pairs of the new PHS.
    pub phs_pairs: u64,
}

/// `bsp` (a Quake 2 file) with its PHS recomputed from the PVS it holds; the compressed bytes of
/// every PVS row are kept as they are. Fails when the file has no visibility lump.
pub fn repair_phs(bsp: &[u8]) -> Result<(Vec<u8>, PhsRepair), BspError> {
    let file = q2::read(bsp)?;
    let Some(vis) = &file.vis else {
        return Err(BspError::Write("the file has no visibility lump (run vis first)".into()));
    };
    let n = vis.num_clusters;
    let words = bits::words(n);
    let pvs = words_from_bytes(&vis.decode_all(Q2Row::Pvs)?, n);
    let old_phs = words_from_bytes(&vis.decode_all(Q2Row::Phs)?, n);
    let new_phs = phs(&pvs, words, n);
    let mut report = PhsRepair { clusters: n, ..PhsRepair::default() };
    for c in 0..n {
        let (old, new) = (&old_phs[c * words..(c + 1) * words], &new_phs[c * words..(c + 1) * words]);
        report.rows_fixed += usize::from(old != new);
        for (a, b) in old.iter().zip(new) {
            report.bits_added += u64::from((b & !a).count_ones());
            report.bits_removed += u64::from((a & !b).count_ones());
        }
    }
    report.pvs_pairs = bits::count(&pvs);
    report.phs_pairs = bits::count(&new_phs);
    let pvs_rows: Vec<&[u8]> = (0..n)
        .map(|c| vis.compressed_row(c, Q2Row::Pvs).ok_or_else(|| BspError::Write(format!("PVS row {c}"))))
        .collect::<Result<_, _>>()?;
    let lump = q2::vis_lump(&pvs_rows, &compress(&new_phs, words, n))?;
    Ok((q2::write_with_visibility(bsp, &lump)?, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phs_is_the_union_of_the_visible_rows() {
        // 0 sees 1, 1 sees 2, 2 sees nothing but itself; 70 clusters so rows span two words.
        let n = 70;
        let words = bits::words(n);
        let mut pvs = vec![0u64; n * words];
        for (a, b) in [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 69), (69, 69)] {
            bits::set(&mut pvs[a * words..(a + 1) * words], b);
        }
        let h = phs(&pvs, words, n);
        let ones = |c: usize| bits::ones(&h[c * words..(c + 1) * words]).collect::<Vec<_>>();
        assert_eq!(ones(0), [0, 1, 2]);
        assert_eq!(ones(1), [1, 2, 69]);
        assert_eq!(ones(2), [2, 69]);
        assert_eq!(ones(3), Vec::<usize>::new());
        let bytes: Vec<u8> = (0..n)
            .flat_map(|c| {
                let mut b = Vec::new();
                bits::to_bytes(&pvs[c * words..(c + 1) * words], bits::bytes::len(n), &mut b);
                b
            })
            .collect();
        assert_eq!(words_from_bytes(&bytes, n), pvs);
        let lump = q2_vis_lump(&pvs, &h, words, n).unwrap();
        let vis = q2::read_vis(&lump, 0).unwrap();
        assert_eq!(words_from_bytes(&vis.decode_all(Q2Row::Phs).unwrap(), n), h);
    }
}
