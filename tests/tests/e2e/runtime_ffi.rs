//! The C ABI: compile a small C program against `runtime/capi/include/sightline.h` and the shared
//! library of `sightline-capi` (built as a dev-dependency of this crate), run it on a level
//! written by the test (and on E1M1 when the shared maps are present), and compare its answers
//! with the Rust API.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use sightline_formats::level::{FaceDraw, Model};
use sightline_formats::slvl;
use sightline_runtime::backend::{Backend, pvs::Pvs};
use sightline_runtime::{Bitset, Camera, Scratch, Visible, World, load};
use sightline_tests::synth;

const PROGRAM: &str = r#"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sightline.h"

static unsigned bits(float f) { uint32_t u; memcpy(&u, &f, sizeof u); return u; }

/* FNV-1a over 64-bit words, as `hash` in the Rust test. */
static unsigned long long hash(const uint64_t *w, size_t n) {
    unsigned long long h = 1469598103934665603ULL;
    for (size_t i = 0; i < n; i++) { h ^= w[i]; h *= 1099511628211ULL; }
    return h;
}

int main(int argc, char **argv) {
    if (argc != 5) return 90;
    SlWorld *world = NULL;
    if (sl_world_load_file("/nonexistent/level.slvl", &world) != SL_ERR_IO || sl_last_error()[0] == 0) return 91;
    int rc = sl_world_load_file(argv[1], &world);
    if (rc != SL_OK) { fprintf(stderr, "load: %d %s\n", rc, sl_last_error()); return 92; }
    float eye[3] = { (float)atof(argv[2]), (float)atof(argv[3]), (float)atof(argv[4]) };
    printf("version %s\n", sl_version());
    uint32_t leaf = 0;
    if (sl_leaf_at(world, eye, &leaf) != SL_OK) return 93;
    printf("leaf %u\n", leaf);
    float to[3] = { eye[0] + 5000.0f, eye[1] + 1000.0f, eye[2] + 500.0f };
    SlTrace tr;
    if (sl_trace(world, eye, to, &tr) != SL_OK) return 94;
    printf("trace %d %.4f %u\n", tr.hit, tr.fraction, tr.leaf);
    SlScratch *scratch = sl_scratch_new(world);
    SlCamera cam = { { eye[0], eye[1], eye[2] }, 30.0f, 0.0f, 0.0f, 73.74f, 4.0f / 3.0f, 1.0f, 65536.0f };
    size_t count = 0;
    if (sl_visible_leaves(world, scratch, &cam, SL_BACKEND_PVS, NULL, 0, &count) != SL_OK) return 95;
    uint32_t *leaves = malloc((count + 1) * sizeof(uint32_t));
    size_t again = 0;
    if (sl_visible_leaves(world, scratch, &cam, SL_BACKEND_PVS, leaves, count, &again) != SL_OK || again != count) return 96;
    printf("visible %zu:", count);
    for (size_t i = 0; i < count; i++) printf(" %u", leaves[i]);
    printf("\n");
    if (sl_visible_leaves(world, scratch, &cam, 7, leaves, count, &again) != SL_ERR_BACKEND) return 97;
    free(leaves);
    /* Visible faces, then the same with back faces culled in the walk. */
    for (int cull = 0; cull < 2; cull++) {
        if (sl_visible_faces(world, scratch, &cam, SL_BACKEND_PVS, cull, NULL, 0, &count) != SL_OK) return 45;
        uint32_t *faces = malloc((count + 1) * sizeof(uint32_t));
        if (sl_visible_faces(world, scratch, &cam, SL_BACKEND_PVS, cull, faces, count, &again) != SL_OK || again != count) return 46;
        printf("faces%d %zu:", cull, count);
        for (size_t i = 0; i < count; i++) printf(" %u", faces[i]);
        printf("\n");
        free(faces);
    }
    if (sl_visible_faces(world, scratch, &cam, SL_BACKEND_PVS, 1, NULL, 1, &count) != SL_ERR_NULL) return 47;
    sl_scratch_free(scratch);

    uint32_t nleaves = sl_world_num_leaves(world), nclusters = sl_world_num_clusters(world);
    uint32_t nfaces = sl_world_num_faces(world), ntextures = sl_world_num_textures(world);
    uint32_t nmodels = sl_world_num_models(world);
    printf("counts %u %u %u %u %u\n", nleaves, nclusters, nfaces, ntextures, nmodels);
    if (sl_world_num_clusters(NULL) != 0 || sl_world_entities(NULL) != NULL) return 60;

    /* Range and null checks. */
    int32_t c = 0;
    SlFace face;
    SlModel model;
    uint32_t u = 0, v = 0;
    size_t n = 0;
    if (sl_leaf_contents(world, nleaves, &c) != SL_ERR_RANGE || sl_last_error()[0] == 0) return 61;
    if (sl_leaf_contents(NULL, 0, &c) != SL_ERR_NULL || sl_leaf_contents(world, 0, NULL) != SL_ERR_NULL) return 62;
    if (sl_leaf_cluster(world, nleaves, &c) != SL_ERR_RANGE) return 63;
    if (sl_pvs_row(world, nclusters, NULL, 0, &n) != SL_ERR_RANGE || sl_phs_row(world, nclusters, NULL, 0, &n) != SL_ERR_RANGE) return 64;
    if (sl_face(world, nfaces, &face) != SL_ERR_RANGE || sl_face_vertices(world, nfaces, NULL, 0, &n) != SL_ERR_RANGE) return 65;
    if (sl_texture_name(world, ntextures) != NULL || sl_texture_size(world, ntextures, &u, &v) != SL_ERR_RANGE) return 66;
    if (sl_model(world, nmodels, &model) != SL_ERR_RANGE || sl_cluster_faces(world, nclusters, NULL, 0, &n) != SL_ERR_RANGE) return 67;
    if (nfaces > 0 && sl_face_vertices(world, 0, NULL, 1, &n) != SL_ERR_NULL) return 68;
    if (sl_leaves_touching(world, eye, NULL, NULL, 0, &n) != SL_ERR_NULL) return 69;

    /* Every point has a leaf; one far outside the world is solid in a sealed map. */
    float outside[3] = { 1.0e6f, 1.0e6f, 1.0e6f };
    int32_t at_eye = 0, at_outside = 0;
    if (sl_leaf_contents(world, leaf, &at_eye) != SL_OK) return 70;
    if (sl_leaf_at(world, outside, &u) != SL_OK || sl_leaf_contents(world, u, &at_outside) != SL_OK) return 71;
    printf("contents %d %d\n", at_eye, at_outside);

    for (uint32_t l = 0; l < nleaves; l++) {
        float mins[3], maxs[3];
        if (sl_leaf_contents(world, l, &c) != SL_OK) return 72;
        int32_t cluster = 0;
        if (sl_leaf_cluster(world, l, &cluster) != SL_OK || sl_leaf_bounds(world, l, mins, maxs) != SL_OK) return 73;
        printf("L%u %d %d %08x %08x %08x %08x %08x %08x\n", l, c, cluster, bits(mins[0]), bits(mins[1]),
               bits(mins[2]), bits(maxs[0]), bits(maxs[1]), bits(maxs[2]));
    }
    uint64_t *row = NULL;
    uint32_t *list = NULL;
    for (uint32_t k = 0; k < nclusters; k++) {
        size_t words = 0, w2 = 0, w3 = 0;
        if (sl_pvs_row(world, k, NULL, 0, &words) != SL_OK) return 74;
        row = realloc(row, (words + 1) * sizeof(uint64_t));
        if (sl_pvs_row(world, k, row, words, &w2) != SL_OK || w2 != words) return 75;
        unsigned long long pvs = hash(row, words);
        if (sl_phs_row(world, k, row, words, &w3) != SL_OK || w3 != words) return 76;
        if (sl_cluster_faces(world, k, NULL, 0, &n) != SL_OK) return 77;
        list = realloc(list, (n + 1) * sizeof(uint32_t));
        if (sl_cluster_faces(world, k, list, n, &n) != SL_OK) return 78;
        printf("C%u %zu %016llx %016llx %zu:", k, words, pvs, hash(row, words), n);
        for (size_t i = 0; i < n; i++) printf(" %u", list[i]);
        printf("\n");
    }
    free(row);

    /* Box queries around the eye and over every leaf's box. */
    float lo[3] = { eye[0] - 100.0f, eye[1] - 100.0f, eye[2] - 100.0f };
    float hi[3] = { eye[0] + 100.0f, eye[1] + 100.0f, eye[2] + 100.0f };
    if (sl_leaves_touching(world, hi, lo, NULL, 0, &n) != SL_OK) return 79;
    list = realloc(list, (n + 1) * sizeof(uint32_t));
    if (sl_leaves_touching(world, hi, lo, list, n, &n) != SL_OK) return 80;
    printf("touching %zu:", n);
    for (size_t i = 0; i < n; i++) printf(" %u", list[i]);
    printf("\nboxes ");
    for (uint32_t l = 0; l < nleaves; l++) {
        float mins[3], maxs[3];
        int32_t visible = 0;
        if (sl_leaf_bounds(world, l, mins, maxs) != SL_OK) return 81;
        if (sl_box_potentially_visible(world, eye, mins, maxs, &visible) != SL_OK) return 82;
        printf("%d", visible);
    }
    printf("\n");

    /* Faces, back-face culled from the eye. */
    list = realloc(list, (nfaces + 1) * sizeof(uint32_t));
    for (uint32_t f = 0; f < nfaces; f++) list[f] = f;
    if (sl_cull_back_faces(world, eye, list, nfaces, &n) != SL_OK) return 83;
    printf("front %zu:", n);
    for (size_t i = 0; i < n; i++) printf(" %u", list[i]);
    printf("\n");
    free(list);
    /* One vertex buffer: every face's vertices are its slice of the level's array. */
    size_t nall = 0;
    if (sl_world_vertices(world, NULL, 0, &nall) != SL_OK) return 40;
    if (nall > 0 && sl_world_vertices(world, NULL, 1, &n) != SL_ERR_NULL) return 41;
    float *all = malloc((3 * nall + 1) * sizeof(float));
    if (sl_world_vertices(world, all, nall, &n) != SL_OK || n != nall) return 42;
    printf("vertices %zu\n", nall);
    float *xyz = NULL;
    for (uint32_t f = 0; f < nfaces; f++) {
        if (sl_face(world, f, &face) != SL_OK) return 84;
        size_t nv = 0;
        if (sl_face_vertices(world, f, NULL, 0, &nv) != SL_OK || nv != face.num_vertices) return 85;
        xyz = realloc(xyz, (3 * nv + 1) * sizeof(float));
        if (sl_face_vertices(world, f, xyz, nv, &nv) != SL_OK) return 86;
        if ((size_t)face.first_vertex + nv > nall) return 43;
        if (nv > 0 && memcmp(xyz, all + 3 * (size_t)face.first_vertex, 3 * nv * sizeof(float)) != 0) return 44;
        printf("F%u %08x %08x %08x %08x t%u d%d @%u", f, bits(face.normal[0]), bits(face.normal[1]),
               bits(face.normal[2]), bits(face.dist), face.texture, face.has_draw, face.first_vertex);
        for (int i = 0; i < 4; i++) printf(" %08x %08x", bits(face.s[i]), bits(face.t[i]));
        printf(" %u %u %u %u %u %d v%zu", face.flags, face.styles[0], face.styles[1], face.styles[2], face.styles[3],
               face.light_offset, nv);
        for (size_t i = 0; i < 3 * nv; i++) printf(" %08x", bits(xyz[i]));
        printf("\n");
    }
    free(xyz);
    free(all);
    for (uint32_t t = 0; t < ntextures; t++) {
        const char *name = sl_texture_name(world, t);
        if (name == NULL || sl_texture_size(world, t, &u, &v) != SL_OK) return 87;
        printf("T%u %s %u %u\n", t, name, u, v);
    }
    for (uint32_t m = 0; m < nmodels; m++) {
        if (sl_model(world, m, &model) != SL_OK) return 88;
        printf("M%u %08x %08x %08x %08x %08x %08x %u %u %08x %08x %08x\n", m, bits(model.mins[0]),
               bits(model.mins[1]), bits(model.mins[2]), bits(model.maxs[0]), bits(model.maxs[1]),
               bits(model.maxs[2]), model.first_face, model.num_faces, bits(model.origin[0]),
               bits(model.origin[1]), bits(model.origin[2]));
    }
    printf("entities %zu\n%s\n", strlen(sl_world_entities(world)), sl_world_entities(world));
    sl_world_free(world);
    return 0;
}
"#;

/// The shared library of `sightline-capi` that cargo built for this crate (in `deps/`, beside
/// this test executable), copied away under its installed name (the SONAME on Linux) so a
/// concurrent build cannot swap it mid-test.
fn library(tmp: &Path) -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?;
    let (built, installed) = if cfg!(target_os = "macos") {
        ("libsightline_capi.dylib", "libsightline.dylib")
    } else {
        ("libsightline_capi.so", "libsightline.so.0")
    };
    let src = [dir.join(built), dir.join("..").join(built), dir.join("deps").join(built)]
        .into_iter()
        .find(|p| p.is_file())?;
    let dst = tmp.join(installed);
    std::fs::copy(&src, &dst).ok()?;
    Some(dst)
}

/// FNV-1a over 64-bit words, as `hash` in the C program.
fn hash(words: &[u64]) -> u64 {
    words.iter().fold(1469598103934665603, |h, &w| (h ^ w).wrapping_mul(1099511628211))
}

/// A float's bits, as the C program prints them.
fn hex(v: impl IntoIterator<Item = f32>) -> String {
    v.into_iter().map(|f| format!(" {:08x}", f.to_bits())).collect()
}

fn expected(world: &World, eye: Vec3) -> String {
    use std::fmt::Write as _;
    let leaf = world.leaf_at(eye);
    let to = eye + Vec3::new(5000.0, 1000.0, 500.0);
    let trace = match world.trace(eye, to) {
        Some(h) => format!("trace 1 {:.4} {}", h.fraction, h.leaf),
        None => "trace 0 1.0000 0".to_string(),
    };
    let cam = Camera { yaw: 30.0, fov_y: 73.74, ..Camera::quake(eye, 30.0, 0.0) };
    let mut out = Visible::default();
    Pvs.cull(world, &cam.view(), &mut Scratch::new(world), &mut out);
    let list = |l: &[u32]| -> String { l.iter().map(|x| format!(" {x}")).collect() };
    let mut faces = String::new();
    for cull in [false, true] {
        let mut out = Visible::default();
        Pvs.cull(world, &cam.view().with_back_face_culling(cull), &mut Scratch::new(world), &mut out);
        faces += &format!("faces{} {}:{}\n", i32::from(cull), out.faces.len(), list(&out.faces));
    }
    let draw = world.draw();
    let contents = |l: u32| world.leaf_contents(l).expect("leaf").code();
    let mut s = format!(
        "version {}\nleaf {leaf}\n{trace}\nvisible {}:{}\n{faces}counts {} {} {} {} {}\ncontents {} {}\n",
        env!("CARGO_PKG_VERSION"),
        out.leaves.len(),
        list(&out.leaves),
        world.num_leaves(),
        world.num_clusters(),
        draw.num_faces(),
        draw.num_textures(),
        draw.models().len(),
        contents(leaf),
        contents(world.leaf_at(Vec3::splat(1.0e6))),
    );
    for l in 0..world.num_leaves() as u32 {
        let b = world.leaf_bounds(l).expect("leaf");
        let cluster = world.leaf_cluster(l).map_or(-1, |c| c as i64);
        let _ = writeln!(
            s,
            "L{l} {} {cluster}{}",
            contents(l),
            hex(b.mins().to_array().into_iter().chain(b.maxs().to_array()))
        );
    }
    let mut pvs = Bitset::default();
    let mut phs = Bitset::default();
    for k in 0..world.num_clusters() {
        world.decode_pvs(k, &mut pvs);
        world.decode_phs(k, &mut phs);
        let faces = draw.cluster_faces(k);
        let _ = writeln!(
            s,
            "C{k} {} {:016x} {:016x} {}:{}",
            pvs.words().len(),
            hash(pvs.words()),
            hash(phs.words()),
            faces.len(),
            list(faces)
        );
    }
    let mut touching = Vec::new();
    world.leaves_touching(eye + 100.0, eye - 100.0, &mut touching);
    let _ = write!(s, "touching {}:{}\nboxes ", touching.len(), list(&touching));
    for l in 0..world.num_leaves() as u32 {
        let b = world.leaf_bounds(l).expect("leaf");
        s.push(if world.box_potentially_visible(eye, b.mins(), b.maxs(), &mut pvs) { '1' } else { '0' });
    }
    let mut front: Vec<u32> = (0..draw.num_faces() as u32).collect();
    world.cull_back_faces(eye, &mut front);
    let _ = writeln!(s, "\nfront {}:{}", front.len(), list(&front));
    let _ = writeln!(s, "vertices {}", draw.vertices().len());
    for f in 0..draw.num_faces() as u32 {
        let v = draw.face(f).expect("face");
        let d = v.draw.copied().unwrap_or(FaceDraw::NONE);
        let st: String = (0..4).map(|i| hex([d.s[i], d.t[i]])).collect();
        let [a, b, c, e] = d.styles;
        let _ = writeln!(
            s,
            "F{f}{} t{} d{} @{}{st} {} {a} {b} {c} {e} {} v{}{}",
            hex(v.normal.to_array().into_iter().chain([v.dist])),
            v.texture,
            i32::from(v.draw.is_some()),
            v.first_vertex,
            d.flags,
            d.light_offset,
            v.vertices.len(),
            hex(v.vertices.iter().flatten().copied()),
        );
    }
    for t in 0..draw.num_textures() as u32 {
        let [w, h] = draw.texture_size(t).unwrap_or([0, 0]);
        let _ = writeln!(s, "T{t} {} {w} {h}", draw.texture_name(t).expect("texture"));
    }
    for (i, m) in draw.models().iter().enumerate() {
        let _ = writeln!(
            s,
            "M{i}{} {} {}{}",
            hex(m.mins.to_array().into_iter().chain(m.maxs.to_array())),
            m.faces.start,
            m.faces.len(),
            hex(m.origin.to_array())
        );
    }
    let _ = writeln!(s, "entities {}\n{}", draw.entities().len(), draw.entities());
    s
}

#[test]
fn c_program_agrees_with_the_rust_api() {
    if Command::new("cc").arg("--version").output().is_err() {
        eprintln!("skipped: no system C compiler `cc` on PATH");
        return;
    }
    let tmp = std::env::temp_dir().join(format!("sightline-ffi-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let lib = library(&tmp).expect("libsightline_capi shared library beside the test executable");
    if cfg!(target_os = "linux")
        && let Ok(elf) = Command::new("readelf").arg("-d").arg(&lib).output()
    {
        let dynamic = String::from_utf8_lossy(&elf.stdout);
        assert!(dynamic.contains("Library soname: [libsightline.so.0]"), "SONAME: {dynamic}");
    }
    let src = tmp.join("prog.c");
    std::fs::write(&src, PROGRAM).expect("write C source");
    let include = sightline_tests::workspace_root().join("runtime/capi/include");
    // The program against the shared library, and (Linux) against the static one with the system
    // libraries `sightline.pc.in` lists in `Libs.private`.
    let compile = |lib: &Path, out: &Path, extra: &[&str]| {
        let cc = Command::new("cc")
            .arg(&src)
            .arg("-std=c99")
            .arg("-Wall")
            .arg("-Werror")
            .arg(format!("-I{}", include.display()))
            .arg(lib)
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .expect("run cc");
        assert!(cc.status.success(), "cc failed: {}", String::from_utf8_lossy(&cc.stderr));
    };
    let rpath = format!("-Wl,-rpath,{}", tmp.display());
    let mut programs = vec![tmp.join("prog")];
    compile(&lib, &programs[0], &[&rpath]);
    if cfg!(target_os = "linux") {
        let built = lib.parent().expect("dir").join("libsightline.a");
        let exe = std::env::current_exe().expect("exe");
        let dir = exe.parent().expect("dir");
        let src = [dir.join("libsightline_capi.a"), dir.join("deps").join("libsightline_capi.a")]
            .into_iter()
            .find(|p| p.is_file())
            .expect("libsightline_capi.a beside the test executable");
        std::fs::copy(src, &built).expect("copy the static library");
        programs.push(tmp.join("prog-static"));
        compile(&built, &programs[1], &["-lpthread", "-ldl", "-lm"]);
    }

    // A level built here, written as .slvl.
    let mut level = synth::grid_level([6, 5, 2], 64.0, true, |x, y, _| x == 3 && y != 2);
    // A brush model placed at its entity's origin.
    level.models.push(Model { num_faces: 2, ..level.models[0] });
    level.entities = "{\n\"classname\" \"worldspawn\"\n}\n\
                      {\n\"classname\" \"func_rotating\"\n\"model\" \"*1\"\n\"origin\" \"8 -16 24.5\"\n}\n"
        .to_string();
    slvl::validate(&level).expect("synthetic level is valid");
    let path = tmp.join("grid.slvl");
    std::fs::write(&path, slvl::write(&level, &slvl::WriteOptions { compress: true })).expect("write level");
    let mut cases = vec![(path.clone(), World::new(&level).expect("world"), Vec3::new(40.0, 40.0, 40.0))];
    if let Some(maps) = sightline_tests::shared_maps() {
        let bsp = maps.join("ericw/e1m1.vis.bsp");
        let world = load::load_path(&bsp).expect("e1m1 loads");
        // Far outside a sealed map is solid.
        assert_eq!(world.leaf_contents(world.leaf_at(Vec3::splat(1.0e6))).map(|c| c.code()), Some(-2));
        cases.push((bsp, world, Vec3::new(480.0, -352.0, 88.0)));
    }
    for (path, world, eye) in &cases {
        let want = expected(world, *eye);
        for prog in &programs {
            let run = Command::new(prog)
                .arg(path)
                .args([eye.x, eye.y, eye.z].map(|v| v.to_string()))
                .output()
                .expect("run the C program");
            let what = format!("{} on {}", prog.display(), path.display());
            assert!(
                run.status.success(),
                "{what} failed ({:?}): {}",
                run.status,
                String::from_utf8_lossy(&run.stderr)
            );
            let got = String::from_utf8_lossy(&run.stdout).to_string();
            for (i, (g, w)) in got.lines().zip(want.lines()).enumerate() {
                assert_eq!(g, w, "{what} line {}", i + 1);
            }
            assert_eq!(got.lines().count(), want.lines().count(), "{what}");
            assert!(got.lines().nth(3).is_some_and(|l| l != "visible 0:"), "something is visible: {got}");
            // Culling in the walk drops some of the visible faces.
            let faces =
                |k: &str| got.lines().find_map(|l| l.strip_prefix(k)).map(|l| l.split_whitespace().count());
            assert!(faces("faces1 ") < faces("faces0 "), "{what}: back faces culled");
            let origins: Vec<_> = world.draw().models().iter().map(|m| m.origin).collect();
            assert!(path != &cases[0].0 || origins[1] == glam::Vec3A::new(8.0, -16.0, 24.5), "{origins:?}");
            // The eye is in open space, and a leaf-contents code tells C about solid.
            assert!(got.contains("\ncontents -1 "), "{what}");
            let solid =
                got.lines().filter(|l| l.starts_with('L') && l.split(' ').nth(1) == Some("-2")).count();
            assert!(solid > 0, "solid leaves are reported as such: {what}");
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
}
