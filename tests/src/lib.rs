//! Helpers shared by the integration tests in `tests/tests/` and the tests, examples and
//! benchmarks of every crate: the shared-maps lookup (a skip becomes a failure under
//! `SIGHTLINE_REQUIRE_MAPS`), input mutation, generated inputs ([`mapgen`]: sealed `.map` text of
//! any size; [`shapes`]: the inputs that cost vis the most for their size; [`heavy`]: open maps
//! for the heavy benchmark set; [`coplanar`]: meshes
//! of many coplanar triangles, the inputs that cost a mesh's outside phase the most), [`runtime_check`]
//! (brute-force reference answers for `sightline-runtime`) and [`synth`] (synthetic levels built
//! in code).

pub mod coplanar;
pub mod heavy;
pub mod mapgen;
pub mod shapes;

use std::path::{Path, PathBuf};

pub mod runtime_check;
pub mod synth;

/// `docs/engine.md`, the engine integration guide, included so that its Rust snippets run as
/// doctests (they build small levels with [`synth`]).
#[cfg(doctest)]
#[doc = include_str!("../../docs/engine.md")]
pub struct EngineGuide;

use sightline_job::rng::SplitMix64;

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The bundled small maps (`maps/` in the workspace).
pub fn bundled_maps() -> PathBuf {
    workspace_root().join("maps")
}

/// The `sightline` binary cargo built beside the running test executable
/// (`target/<profile>/sightline`; a test executable sits in `target/<profile>/deps`). `cargo test
/// --workspace` builds it, since this crate dev-depends on the `sightline` package; panics,
/// saying so, when it is missing.
pub fn sightline_binary() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable");
    let dir = exe.parent().and_then(Path::parent).expect("target/<profile>");
    let bin = dir.join(format!("sightline{}", std::env::consts::EXE_SUFFIX));
    assert!(
        bin.is_file(),
        "{} is missing: run `cargo test --profile test-opt` (or build -p sightline)",
        bin.display()
    );
    bin
}

/// Set (to anything but `0` or empty) in CI: a missing shared map is a test failure, not a skip.
pub const REQUIRE_MAPS: &str = "SIGHTLINE_REQUIRE_MAPS";

/// True when [`REQUIRE_MAPS`] is set: every real-map skip becomes a panic.
pub fn maps_required() -> bool {
    std::env::var_os(REQUIRE_MAPS).is_some_and(|v| !v.is_empty() && v != "0")
}

/// The shared real maps (id's GPL release, LibreQuake, the reference compilers' outputs; never
/// copied into the project): `$SIGHTLINE_MAPS`, or `../shared/maps` beside the workspace. Returns
/// `None`, after printing why, when the folder is absent, so a test can skip its real-map part
/// visibly rather than silently; panics instead when [`maps_required`].
pub fn shared_maps() -> Option<PathBuf> {
    let dir = std::env::var_os("SIGHTLINE_MAPS")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("../shared/maps"));
    if dir.is_dir() {
        return Some(dir);
    }
    missing(&format!("real maps not found at {} (set SIGHTLINE_MAPS)", dir.display()));
    None
}

/// Says that a real map is missing: a note, or a panic when [`maps_required`].
pub fn missing(what: &str) {
    if maps_required() {
        panic!("{what}, and {REQUIRE_MAPS} is set: real-map checks may not be skipped");
    }
    eprintln!("note: {what}; its checks are not run");
}

/// The file `rel` (for example `ericw/e1m1.prt`) under [`shared_maps`], or `None`, after printing
/// why, when the maps or that file are absent.
pub fn shared_map(rel: &str) -> Option<PathBuf> {
    let p = shared_maps()?.join(rel);
    if p.is_file() {
        Some(p)
    } else {
        missing(&format!("{} missing", p.display()));
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

/// Re-encodes a BSP29 file as BSP2 (`rmq == false`) or BSP2-RMQ: the lumps whose records widen
/// are rebuilt from the parsed file, the others copied; lumps are laid out in index order.
pub fn widen_bsp(bytes: &[u8], bsp: &sightline_formats::bsp::Bsp, rmq: bool) -> Vec<u8> {
    fn put<T: Copy, const N: usize>(out: &mut Vec<u8>, values: &[T], f: impl Fn(T) -> [u8; N]) {
        values.iter().for_each(|&v| out.extend_from_slice(&f(v)));
    }
    let bounds = |out: &mut Vec<u8>, v: [f32; 3]| {
        for c in v {
            if rmq {
                out.extend_from_slice(&(c as i16).to_le_bytes());
            } else {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    };
    let mut lumps: Vec<Vec<u8>> = bsp.lumps.iter().map(|l| bytes[l.offset..l.end()].to_vec()).collect();
    let mut nodes = Vec::new();
    for n in &bsp.nodes {
        nodes.extend_from_slice(&(n.plane as i32).to_le_bytes());
        put(&mut nodes, &n.children, i32::to_le_bytes);
        bounds(&mut nodes, n.mins);
        bounds(&mut nodes, n.maxs);
        put(&mut nodes, &[n.first_face, n.num_faces], u32::to_le_bytes);
    }
    lumps[sightline_formats::bsp::lump::NODES] = nodes;
    let mut leaves = Vec::new();
    for l in &bsp.leaves {
        put(&mut leaves, &[l.contents, l.visofs], i32::to_le_bytes);
        bounds(&mut leaves, l.mins);
        bounds(&mut leaves, l.maxs);
        put(&mut leaves, &[l.first_marksurface, l.num_marksurfaces], u32::to_le_bytes);
        leaves.extend_from_slice(&l.ambient);
    }
    lumps[sightline_formats::bsp::lump::LEAVES] = leaves;
    let mut faces = Vec::new();
    for f in &bsp.faces {
        put(
            &mut faces,
            &[f.plane, u32::from(f.back), f.first_edge, f.num_edges, f.texinfo],
            u32::to_le_bytes,
        );
        faces.extend_from_slice(&f.styles);
        faces.extend_from_slice(&f.light_offset.to_le_bytes());
    }
    lumps[sightline_formats::bsp::lump::FACES] = faces;
    let old_clip = &lumps[sightline_formats::bsp::lump::CLIPNODES];
    let mut clip = Vec::new();
    for rec in old_clip.chunks_exact(8) {
        clip.extend_from_slice(&rec[..4]);
        for c in [&rec[4..6], &rec[6..8]] {
            // Clip children are contents codes (negative) or clipnode indices.
            let v = i16::from_le_bytes([c[0], c[1]]);
            let v = if v >= -15 { i32::from(v) } else { i32::from(v as u16) };
            clip.extend_from_slice(&v.to_le_bytes());
        }
    }
    lumps[sightline_formats::bsp::lump::CLIPNODES] = clip;
    let mut marks = Vec::new();
    put(&mut marks, &bsp.marksurfaces, u32::to_le_bytes);
    lumps[sightline_formats::bsp::lump::MARKSURFACES] = marks;
    let mut edges = Vec::new();
    for e in &bsp.edges {
        put(&mut edges, e, u32::to_le_bytes);
    }
    lumps[sightline_formats::bsp::lump::EDGES] = edges;

    let mut out = if rmq { b"2PSB".to_vec() } else { b"BSP2".to_vec() };
    out.resize(sightline_formats::bsp::HEADER_BYTES, 0);
    for (i, data) in lumps.iter().enumerate() {
        out.resize(out.len().next_multiple_of(4), 0);
        let at = 4 + i * 8;
        let (offset, length) = (out.len() as i32, data.len() as i32);
        out[at..at + 4].copy_from_slice(&offset.to_le_bytes());
        out[at + 4..at + 8].copy_from_slice(&length.to_le_bytes());
        out.extend_from_slice(data);
    }
    out
}
