//! Hostile input: thousands of mutated files (truncations, bit flips, random bytes, huge counts
//! spliced into headers, shuffled chunks) for every reader, asserting that none panics and that
//! none allocates beyond a bound linear in the input.
//!
//! A counting global allocator tracks, per thread, the bytes currently allocated and the peak
//! since the last reset, so tests running on other threads do not disturb a measurement.

use sightline_formats::{FileKind, bsp, map, obj, prt, rle, slvl, visfile};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static CURRENT: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn note(delta: isize) {
    // `try_with` because allocation can happen while thread-locals are being torn down.
    let _ = CURRENT.try_with(|c| {
        let now = c.get() + delta;
        c.set(now);
        let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
    });
}

// SAFETY: every method forwards to `System` with the same arguments; the bookkeeping only touches
// const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note(-(layout.size() as isize));
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size as isize - layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` and returns the peak number of bytes it held allocated at once on this thread.
fn peak_during(f: impl FnOnce()) -> usize {
    let base = CURRENT.with(Cell::get);
    PEAK.with(|p| p.set(base));
    f();
    (PEAK.with(Cell::get) - base).max(0) as usize
}

use sightline_formats::rng::SplitMix64 as Rng;
use sightline_tests::mutate;

/// Values that break naive readers when they land in a count, offset or length field.
/// Text mutation: byte mutations as above, plus numbers made huge or non-finite and braces and
/// parentheses inserted or deleted.
fn mutate_text(rng: &mut Rng, input: &[u8]) -> String {
    let bytes = if rng.below(3) == 0 {
        let mut out = input.to_vec();
        let at = rng.below(out.len() + 1);
        let token: &[u8] = [
            &b"99999999999999999999"[..],
            b"1e300",
            b"nan",
            b"-inf",
            b"{",
            b"}",
            b"(",
            b")",
            b"\"",
            b"4294967295",
            b"-1",
            b"\n",
        ][rng.below(12)];
        if rng.below(2) == 0 || at == out.len() {
            out.splice(at..at, token.iter().copied());
        } else {
            out.remove(at);
        }
        out
    } else {
        mutate(rng, input, 64)
    };
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Memory a reader may take for an input of `len` bytes.
fn linear_bound(len: usize) -> usize {
    64 * len + (16 << 20)
}

/// Runs `read` on `count` mutations of each input, checking the memory bound; returns how many
/// mutations were rejected (so a caller can check the readers really do reject).
fn hammer(
    name: &str,
    inputs: &[Vec<u8>],
    count: usize,
    seed: u64,
    mut mutation: impl FnMut(&mut Rng, &[u8]) -> Vec<u8>,
    bound: impl Fn(usize) -> usize,
    mut read: impl FnMut(&[u8]) -> bool,
) -> usize {
    let mut rng = Rng::new(seed);
    let mut rejected = 0;
    let mut worst = 0usize;
    for input in inputs {
        for i in 0..count {
            let data = mutation(&mut rng, input);
            let mut ok = true;
            let peak = peak_during(|| ok = read(&data));
            rejected += usize::from(!ok);
            worst = worst.max(peak);
            assert!(
                peak <= bound(data.len()),
                "{name}: mutation {i} of a {}-byte input ({} bytes) took {peak} bytes at peak",
                input.len(),
                data.len()
            );
        }
    }
    let largest = inputs.iter().map(Vec::len).max().unwrap_or(0);
    eprintln!(
        "{name}: {rejected} of {} mutations rejected; peak allocation {worst} bytes (largest input {largest} bytes)",
        inputs.len() * count
    );
    rejected
}

fn shared(path: &str) -> Option<Vec<u8>> {
    let dir = sightline_tests::shared_maps()?;
    Some(std::fs::read(dir.join(path)).unwrap_or_else(|e| panic!("{path}: {e}")))
}

fn bundled(name: &str) -> Vec<u8> {
    let path = sightline_tests::bundled_maps().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bundled_with_ext(ext: &str) -> Vec<Vec<u8>> {
    let dir = sightline_tests::bundled_maps();
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).expect("read bundled map")).collect()
}

#[test]
fn rle_rows_survive_hostile_bytes() {
    let mut rng = Rng::new(1);
    let mut inputs = Vec::new();
    for _ in 0..20 {
        let row: Vec<u8> = (0..1 + rng.below(400))
            .map(|_| if rng.below(4) == 0 { rng.next_u64() as u8 } else { 0 })
            .collect();
        let mut packed = Vec::new();
        rle::encode_row(&row, &mut packed);
        inputs.push(packed);
    }
    let rejected = hammer(
        "rle",
        &inputs,
        300,
        2,
        |r, d| mutate(r, d, 8),
        linear_bound,
        |data| {
            // A row far longer than the input could fill is refused before anything is allocated.
            assert!(rle::decode_row_vec(data, usize::MAX / 2).is_err());
            rle::decode_row_vec(data, data.len() * 3).is_ok()
        },
    );
    assert!(rejected > 1000, "only {rejected} of 6000 mutated rows rejected");
}

#[test]
fn bsp_reader_survives_hostile_files() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let plain = shared("ericw/dm1.bsp").expect("dm1.bsp beside dm1.vis.bsp");
    let rejected = hammer(
        "bsp",
        &[vis, plain],
        1500,
        3,
        |r, d| mutate(r, d, bsp::HEADER_BYTES),
        linear_bound,
        |data| match bsp::read(data) {
            Ok(b) => {
                // A file that reads must answer every query without panicking.
                let _ = b.pvs_stats();
                // ...and convert to a level that passes `.slvl` validation.
                assert_eq!(slvl::validate(&bsp::to_level(&b)), Ok(()));
                let visofs: Vec<i32> = b.leaves.iter().map(|l| l.visofs).collect();
                let _ = bsp::write_with_visdata(data, &b.visdata, &visofs, None);
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 1000, "only {rejected} of 3000 mutated BSPs rejected");
}

/// `.slvl` files expand lz4 lumps: the reader allows all lumps together
/// `slvl::MAX_TOTAL_EXPANSION` times the file size plus 16 MiB, and parsed records take at most
/// a few times their bytes, so the bound is wider than for the other readers.
fn slvl_bound(len: usize) -> usize {
    8 * (slvl::MAX_TOTAL_EXPANSION as usize * len + (16 << 20))
}

#[test]
fn slvl_reader_survives_hostile_files() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let level = bsp::to_level(&bsp::read(&vis).expect("dm1 reads"));
    let inputs = [
        slvl::write(&level, &slvl::WriteOptions { compress: false }),
        slvl::write(&level, &slvl::WriteOptions { compress: true }),
    ];
    let header = slvl::HEADER_BYTES + slvl::LumpKind::ALL.len() * slvl::DIR_ENTRY_BYTES;
    let rejected = hammer(
        "slvl",
        &inputs,
        1500,
        4,
        |r, d| mutate(r, d, header),
        slvl_bound,
        |data| match slvl::read(data) {
            Ok(level) => {
                // A level that reads must answer PVS queries without panicking.
                let _ = level.pvs_stats();
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 2000, "only {rejected} of 3000 mutated .slvl files rejected");
}

/// A `.slvl` whose checksums were recomputed after the mutation reaches the record validation,
/// which checksums otherwise stop first.
#[test]
fn slvl_validation_survives_mutated_records() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let level = bsp::to_level(&bsp::read(&vis).expect("dm1 reads"));
    let raw = slvl::write(&level, &slvl::WriteOptions { compress: false });
    let entries = slvl::directory(&raw).expect("directory");
    let header = slvl::HEADER_BYTES + entries.len() * slvl::DIR_ENTRY_BYTES;
    let fix_checksums = |data: &mut Vec<u8>| {
        for (i, e) in entries.iter().enumerate() {
            let (start, end) = (e.offset as usize, (e.offset + e.length) as usize);
            let at = slvl::HEADER_BYTES + i * slvl::DIR_ENTRY_BYTES + 32;
            if end <= data.len() && at + 4 <= header {
                let sum = slvl::crc32(&data[start..end]).to_le_bytes();
                data[at..at + 4].copy_from_slice(&sum);
            }
        }
    };
    let rejected = hammer(
        "slvl records",
        std::slice::from_ref(&raw),
        1500,
        5,
        |r, d| {
            // Keep the header and directory intact so the mutation hits records.
            let mut body = mutate(r, &d[header..], 0);
            body.resize(d.len() - header, 0);
            let mut out = d[..header].to_vec();
            out.extend_from_slice(&body);
            fix_checksums(&mut out);
            out
        },
        slvl_bound,
        |data| slvl::read(data).is_ok(),
    );
    assert!(rejected > 500, "only {rejected} of 1500 mutated records rejected");
}

#[test]
fn vis_file_reader_survives_hostile_files() {
    let mut rng = Rng::new(12);
    let mut inputs = Vec::new();
    for _ in 0..10 {
        let leaves = 1 + rng.below(300);
        let row_bytes = leaves.div_ceil(8);
        let (mut data, mut offsets) = (Vec::new(), Vec::new());
        for _ in 0..leaves {
            offsets.push(data.len() as u32);
            let row: Vec<u8> =
                (0..row_bytes).map(|_| if rng.below(3) == 0 { rng.next_u64() as u8 } else { 0 }).collect();
            rle::encode_row(&row, &mut data);
        }
        inputs.push(visfile::write(row_bytes, &offsets, &data).expect("small file"));
    }
    let rejected = hammer(
        "vis file",
        &inputs,
        300,
        13,
        |r, d| mutate(r, d, visfile::HEADER_BYTES),
        linear_bound,
        |data| match visfile::read(data) {
            Ok(f) => {
                // Every row of a file that reads decodes or fails cleanly.
                for &o in &f.leaf_offsets {
                    let _ = rle::decode_row_vec(&f.data[o as usize..], f.row_bytes as usize);
                }
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 1500, "only {rejected} of 3000 mutated .vis files rejected");
}

#[test]
fn file_kind_detection_survives_hostile_bytes() {
    let mut inputs = bundled_with_ext("map");
    inputs.extend(bundled_with_ext("obj"));
    let mut rng = Rng::new(14);
    let mut kinds = 0;
    for input in &inputs {
        for _ in 0..200 {
            let data = mutate(&mut rng, input, 16);
            let peak = peak_during(|| kinds += usize::from(FileKind::from_bytes(&data).is_some()));
            assert!(peak <= linear_bound(data.len()), "detection took {peak} bytes");
        }
    }
    assert!(kinds > 0, "no mutated map or mesh was recognised");
}

#[test]
fn map_parser_survives_hostile_text() {
    let mut inputs = bundled_with_ext("map");
    let real = shared("id/dm1.map");
    let rejected = hammer(
        "map",
        &inputs,
        150,
        6,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| map::parse(std::str::from_utf8(data).unwrap_or_default(), "hostile.map").is_ok(),
    );
    assert!(rejected > inputs.len() * 50, "only {rejected} mutated maps rejected");
    if let Some(real) = real {
        inputs = vec![real];
        hammer(
            "map (dm1)",
            &inputs,
            60,
            7,
            |r, d| mutate_text(r, d).into_bytes(),
            linear_bound,
            |data| map::parse(std::str::from_utf8(data).unwrap_or_default(), "dm1.map").is_ok(),
        );
    }
}

#[test]
fn prt_reader_survives_hostile_text() {
    let Some(dm1) = shared("ericw/dm1.prt") else { return };
    let lqdm1 = shared("ericw/lqdm1.prt").expect("lqdm1.prt");
    let rejected = hammer(
        "prt",
        &[dm1, lqdm1],
        400,
        8,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| prt::read(std::str::from_utf8(data).unwrap_or_default(), "hostile.prt").is_ok(),
    );
    assert!(rejected > 400, "only {rejected} of 800 mutated portal files rejected");
}

#[test]
fn obj_loader_survives_hostile_text() {
    let inputs = bundled_with_ext("obj");
    assert!(!inputs.is_empty(), "maps/ has an .obj");
    let scene = bundled("scene.obj");
    assert!(inputs.contains(&scene));
    let rejected = hammer(
        "obj",
        &inputs,
        1000,
        9,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| obj::load_from_bytes(data, "hostile.obj").is_ok(),
    );
    // Many mutations of an .obj stay valid (tobj skips unknown lines): only require some rejections.
    assert!(rejected > 50, "only {rejected} mutated .obj files rejected");
}
