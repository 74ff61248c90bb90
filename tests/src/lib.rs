//! Helpers shared by the integration tests in `tests/tests/`.

use std::path::PathBuf;

use sightline_formats::rng::SplitMix64;

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The bundled small maps (`maps/` in the workspace).
pub fn bundled_maps() -> PathBuf {
    workspace_root().join("maps")
}

/// The shared real maps: `$SIGHTLINE_MAPS`, or `../shared/maps` beside the workspace. Returns
/// `None`, after printing why, when the folder is absent, so a test can skip its real-map part
/// visibly rather than silently.
pub fn shared_maps() -> Option<PathBuf> {
    let dir = sightline_formats::shared_maps::dir();
    if dir.is_none() {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); real-map checks are not run");
    }
    dir
}

/// The file `rel` (for example `ericw/e1m1.prt`) under [`shared_maps`], or `None`, after printing
/// why, when the maps or that file are absent.
pub fn shared_map(rel: &str) -> Option<PathBuf> {
    let p = shared_maps()?.join(rel);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("note: {} missing; its checks are not run", p.display());
        None
    }
}

/// Counts and offsets that overflow or overreach, spliced in by [`mutate`].
const HUGE: [u32; 8] =
    [u32::MAX, 0x7fff_ffff, 0x8000_0000, 0xffff_fff0, 0x0100_0000, 0xffff, 0x1_0000, 0xfff_ffff];

/// One random mutation of a binary file `input`: a truncation, bit flips, random bytes, a huge
/// count spliced in, a chunk copied elsewhere, or junk inserted. `header` is the size of the region where counts and offsets
/// live (spliced values land there half of the time).
pub fn mutate(rng: &mut SplitMix64, input: &[u8], header: usize) -> Vec<u8> {
    let mut out = input.to_vec();
    if out.is_empty() {
        return vec![rng.next_u64() as u8; rng.below(64)];
    }
    match rng.below(6) {
        0 => out.truncate(rng.below(input.len())),
        1 => {
            for _ in 0..1 + rng.below(8) {
                let at = rng.below(out.len());
                out[at] ^= 1 << rng.below(8);
            }
        }
        2 => {
            let at = rng.below(out.len());
            let n = (1 + rng.below(32)).min(out.len() - at);
            out[at..at + n].iter_mut().for_each(|b| *b = rng.next_u64() as u8);
        }
        3 => {
            let region = if rng.below(2) == 0 { header.min(out.len()) } else { out.len() };
            let at = rng.below(region.saturating_sub(3).max(1)) & !3;
            let value = HUGE[rng.below(HUGE.len())].to_le_bytes();
            let n = 4.min(out.len() - at.min(out.len()));
            out[at..at + n].copy_from_slice(&value[..n]);
        }
        4 => {
            // Copy a chunk over another place (duplicated records, shifted structure).
            let n = 1 + rng.below(256.min(out.len()));
            let from = rng.below(out.len() - n + 1);
            let to = rng.below(out.len() - n + 1);
            let chunk = out[from..from + n].to_vec();
            out[to..to + n].copy_from_slice(&chunk);
        }
        _ => {
            let at = rng.below(out.len() + 1);
            let junk: Vec<u8> = (0..1 + rng.below(64)).map(|_| rng.next_u64() as u8).collect();
            out.splice(at..at, junk);
        }
    }
    out
}
