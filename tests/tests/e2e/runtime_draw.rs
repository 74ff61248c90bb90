//! The runtime's draw data and box queries on real Quake maps: faces equal the source BSP's
//! (count, vertices, planes, texture names and projections, light fields, models), every sampled
//! point of a box lies in a leaf `leaves_touching` reports, every leaf a traced sight line from
//! the eye reaches is in a box `box_potentially_visible` accepts, and the PHS is the union of PVS rows.

use glam::Vec3A;
use sightline_formats::bsp;
use sightline_formats::entities::Entity;
use sightline_formats::level::Contents;
use sightline_runtime::poses::{SplitMix64, point_in, random_open_point};
use sightline_runtime::{Bitset, World, load};
use sightline_tests::runtime_check::sampled_leaves;

use super::runtime_real_maps::world_box;

/// Quake `.bsp` files with visdata under the shared maps, read both ways.
fn maps() -> Vec<(&'static str, bsp::Bsp, World)> {
    ["ericw/e1m1.vis.bsp", "ericw/dm2.vis.bsp", "ericw/e1m3.vis.bsp"]
        .into_iter()
        .filter_map(|rel| {
            let path = sightline_tests::shared_map(rel)?;
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let parsed = bsp::read(&bytes).unwrap_or_else(|e| panic!("{rel}: {e}"));
            let world = load::load_bytes(&bytes).unwrap_or_else(|e| panic!("{rel}: {e}"));
            Some((rel, parsed, world))
        })
        .collect()
}

/// id's maps as compiled with textures and light (`id_bsp_orig`; the ericw builds have no
/// embedded textures), read both ways.
fn textured_maps() -> Vec<(&'static str, bsp::Bsp, World)> {
    ["id_bsp_orig/e1m1.bsp", "id_bsp_orig/dm2.bsp"]
        .into_iter()
        .filter_map(|rel| {
            let path = sightline_tests::shared_map(rel)?;
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            Some((rel, bsp::read(&bytes).expect(rel), load::load_bytes(&bytes).expect(rel)))
        })
        .collect()
}

#[test]
fn faces_equal_the_source_bsp_faces() {
    let textured = textured_maps();
    for (name, _, world) in &textured {
        let draw = world.draw();
        let named = (0..draw.num_faces() as u32)
            .filter(|&f| {
                draw.face(f).and_then(|f| draw.texture_name(f.texture)).is_some_and(|n| !n.is_empty())
            })
            .count();
        assert_eq!(named, draw.num_faces(), "{name}: every face has a texture name");
        let lit = (0..draw.num_faces() as u32)
            .filter(|&f| draw.face(f).and_then(|f| f.draw).is_some_and(|d| d.light_offset >= 0));
        assert!(lit.count() > draw.num_faces() / 2, "{name}: light maps");
    }
    let maps: Vec<_> = maps().into_iter().chain(textured).collect();
    if maps.is_empty() {
        eprintln!("shared maps absent: draw data not compared with real BSPs");
    }
    for (name, b, world) in maps {
        let draw = world.draw();
        assert_eq!(draw.num_faces(), b.faces.len(), "{name}: face count");
        assert!(draw.has_face_draw(), "{name}: texture projections");
        for (i, f) in b.faces.iter().enumerate() {
            let face = draw.face(i as u32).expect("face in range");
            let corners: Vec<[f32; 3]> = b.face_vertex_indices(f).map(|v| b.vertices[v as usize]).collect();
            assert_eq!(face.vertices, corners.as_slice(), "{name}: face {i} corners");
            let plane = b.planes[f.plane as usize];
            let sign = if f.back { -1.0 } else { 1.0 };
            let normal = Vec3A::from_array(plane.normal) * sign;
            assert!((face.normal - normal).length() < 1e-5, "{name}: face {i} normal");
            assert!((face.dist - plane.dist * sign).abs() < 1e-3, "{name}: face {i} dist");
            let info = b.texinfo[f.texinfo as usize];
            let want_name = b.textures[info.miptex as usize].as_ref().map_or("", |t| t.name.as_str());
            assert_eq!(draw.texture_name(face.texture), Some(want_name), "{name}: face {i} texture");
            let d = face.draw.expect("projection");
            assert_eq!([d.s, d.t], info.vecs, "{name}: face {i} texture axes");
            assert_eq!((d.styles, d.light_offset), (f.styles, f.light_offset), "{name}: face {i} light");
            if let Some(t) = &b.textures[info.miptex as usize] {
                assert_eq!(draw.texture_size(face.texture), Some([t.width, t.height]), "{name}: size");
            }
        }
        assert_eq!(draw.models().len(), b.models.len(), "{name}: models");
        for (m, bm) in draw.models().iter().zip(&b.models) {
            assert_eq!(m.faces, bm.first_face..bm.first_face + bm.num_faces, "{name}: model faces");
            assert_eq!((m.mins.to_array(), m.maxs.to_array()), (bm.mins, bm.maxs), "{name}: model bounds");
        }
        // Per cluster: exactly the union of its leaves' faces.
        for c in 0..world.num_clusters() {
            let mut want: Vec<u32> =
                world.cluster_leaves(c).iter().flat_map(|&l| world.leaf_faces(l).iter().copied()).collect();
            want.sort_unstable();
            want.dedup();
            assert_eq!(draw.cluster_faces(c), want.as_slice(), "{name}: cluster {c} faces");
        }
    }
}

/// Entities through the draw API: every brush model but the world is named by one entity (doors
/// among them), and a model's origin is its entity's `origin` (zero without one: Quake 1's doors
/// have none; a model with one is checked on a synthetic level in the runtime's unit tests).
#[test]
fn brush_models_take_their_entity_origin() {
    let mut checked = 0;
    for (name, _, world) in maps().into_iter().chain(textured_maps()) {
        let draw = world.draw();
        let ents = draw.entity_list();
        assert_eq!(ents.first().map(|e| e.classname()), Some("worldspawn"), "{name}");
        let doors: Vec<_> = ents.iter().filter(|e| e.classname() == "func_door").collect();
        assert!(!doors.is_empty(), "{name}: doors");
        for m in 1..draw.models().len() as u32 {
            let named: Vec<_> = ents.iter().filter(|e| e.model() == Some(m)).collect();
            assert_eq!(named.len(), 1, "{name}: model {m} named once");
            let want = named[0].origin().map_or([0.0; 3], |o| o.expect("finite origin"));
            assert_eq!(draw.models()[m as usize].origin.to_array(), want, "{name}: model {m} origin");
        }
        let models = draw.models();
        let door_origin = |d: &&Entity| d.model().and_then(|m| models.get(m as usize)).map(|m| m.origin);
        assert!(doors.iter().all(|d| door_origin(d) == Some(Vec3A::ZERO)), "{name}: {} models", models.len());
        checked += 1;
    }
    if checked == 0 {
        eprintln!("shared maps absent: brush model origins not checked");
    }
}

#[test]
fn leaves_touching_holds_every_sampled_point_of_the_box() {
    for (name, _, world) in maps() {
        let (lo, hi) = world_box(&world);
        let mut rng = SplitMix64::new(23);
        let mut out = Vec::new();
        let (mut total, mut boxes) = (0usize, 0usize);
        for i in 0..300 {
            let centre = if i % 3 == 0 {
                point_in(&mut rng, lo, hi)
            } else {
                random_open_point(&world, &mut rng).expect("open")
            };
            let half = Vec3A::new(
                1.0 + rng.below(128) as f32,
                1.0 + rng.below(128) as f32,
                1.0 + rng.below(64) as f32,
            );
            let (a, b) = (centre - half, centre + half);
            world.leaves_touching(a, b, &mut out);
            let mut sorted = out.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), out.len(), "{name}: a leaf reported twice");
            for _ in 0..200 {
                let p = point_in(&mut rng, a, b);
                let leaf = world.leaf_at(p);
                if world.leaf_contents(leaf).is_some_and(|c| c.is_open()) {
                    assert!(out.contains(&leaf), "{name}: box {a:?}..{b:?} misses leaf {leaf} at {p:?}");
                }
            }
            total += out.len();
            boxes += 1;
        }
        // Not trivially everything (the grid test in `runtime::query` checks tightness exactly; BSP
        // leaf bounds here are not the leaves' cells).
        assert!(total < boxes * world.open_leaves().len() / 50, "{name}: boxes touch almost every leaf");
    }
}

#[test]
fn boxes_around_sighted_leaves_are_potentially_visible() {
    for (name, _, world) in maps() {
        let mut rng = SplitMix64::new(41);
        let (lo, hi) = world_box(&world);
        let mut row = Bitset::default();
        let (mut hidden, mut checked) = (0usize, 0usize);
        for _ in 0..60 {
            // An eye in open air or liquid (sky leaves are open but see nothing beyond the sky).
            let eye = loop {
                let p = random_open_point(&world, &mut rng).expect("open");
                if world.leaf_contents(world.leaf_at(p)) != Some(Contents::Sky) {
                    break p;
                }
            };
            for _ in 0..40 {
                // The open part of the sight line: up to the first solid leaf (traced), and up
                // to the first sky leaf (open, but opaque to sight).
                let to = point_in(&mut rng, lo, hi);
                let to = world.trace(eye, to).map_or(to, |hit| hit.point);
                for (t, leaf) in sampled_leaves(&world, eye, to, 400) {
                    if !world.leaf_contents(leaf).is_some_and(|c| c.is_open() && c != Contents::Sky) {
                        break;
                    }
                    let p = eye + (to - eye) * t;
                    let r = Vec3A::splat(0.5);
                    assert!(
                        world.box_potentially_visible(eye, p - r, p + r, &mut row),
                        "{name}: box at {p:?} (leaf {leaf}) reached from {eye:?} is not potentially visible"
                    );
                    checked += 1;
                }
            }
            // Some boxes are hidden: the query is not trivially true.
            for _ in 0..20 {
                let p = random_open_point(&world, &mut rng).expect("open");
                let r = Vec3A::splat(0.5);
                hidden += usize::from(!world.box_potentially_visible(eye, p - r, p + r, &mut row));
            }
        }
        assert!(checked > 1000, "{name}: {checked} sighted boxes");
        assert!(hidden > 0, "{name}: every random box visible");
    }
}

#[test]
fn phs_is_the_union_of_pvs_rows() {
    for (name, _, world) in maps() {
        let n = world.num_clusters();
        let rows: Vec<Bitset> = (0..n)
            .map(|c| {
                let mut r = Bitset::default();
                world.decode_pvs(c, &mut r);
                r
            })
            .collect();
        let mut phs = Bitset::default();
        let mut grew = 0;
        for c in 0..n {
            let mut want = rows[c as usize].clone();
            for j in rows[c as usize].iter_ones() {
                for k in rows[j].iter_ones() {
                    want.set(k);
                }
            }
            world.decode_phs(c, &mut phs);
            assert_eq!(phs, want, "{name}: PHS row {c}");
            grew += usize::from(phs.count_ones() > rows[c as usize].count_ones());
        }
        assert!(grew > 0, "{name}: the PHS never exceeds the PVS");
        // Out of range (the eye in solid): everything.
        world.decode_phs(n, &mut phs);
        assert_eq!(phs.count_ones(), n as usize, "{name}");
    }
}

/// A Quake 2 BSP's faces read straight from its lumps (`qfiles.h`), apart from the reader under
/// test: corners, plane side, texinfo (axes, flags, name), light styles and offset.
struct Q2Face {
    corners: Vec<[f32; 3]>,
    plane: usize,
    back: bool,
    axes: [[f32; 4]; 2],
    flags: u32,
    name: String,
    styles: [u8; 4],
    light_offset: i32,
}

fn q2_faces(b: &[u8]) -> (Vec<Q2Face>, Vec<([f32; 3], f32)>) {
    let u32_at = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"));
    let f32_at = |at: usize| f32::from_bits(u32_at(at));
    let u16_at = |at: usize| usize::from(u16::from_le_bytes([b[at], b[at + 1]]));
    let lump = |i: usize| (u32_at(8 + 8 * i) as usize, u32_at(12 + 8 * i) as usize);
    let vec3 = |at: usize| [f32_at(at), f32_at(at + 4), f32_at(at + 8)];
    let ((planes, np), (verts, _), (texinfo, _), (faces, nf)) = (lump(1), lump(2), lump(5), lump(6));
    let ((edges, _), (surfedges, _)) = (lump(11), lump(12));
    let planes = (0..np / 20).map(|i| (vec3(planes + 20 * i), f32_at(planes + 20 * i + 12))).collect();
    let faces = (0..nf / 20)
        .map(|i| {
            let at = faces + 20 * i;
            let (first, count, info) =
                (u32_at(at + 4) as usize, u16_at(at + 8), texinfo + 76 * u16_at(at + 10));
            let corners = (first..first + count)
                .map(|k| {
                    let e = u32_at(surfedges + 4 * k) as i32;
                    let edge = edges + 4 * e.unsigned_abs() as usize;
                    verts + 12 * if e >= 0 { u16_at(edge) } else { u16_at(edge + 2) }
                })
                .map(vec3)
                .collect();
            let name = &b[info + 40..info + 72];
            let name = &name[..name.iter().position(|&c| c == 0).unwrap_or(32)];
            Q2Face {
                corners,
                plane: u16_at(at),
                back: u16_at(at + 2) != 0,
                axes: [0, 16].map(|o| [0, 4, 8, 12].map(|k| f32_at(info + o + k))),
                flags: u32_at(info + 32),
                name: String::from_utf8_lossy(name).into_owned(),
                styles: [b[at + 12], b[at + 13], b[at + 14], b[at + 15]],
                light_offset: u32_at(at + 16) as i32,
            }
        })
        .collect();
    (faces, planes)
}

/// Quake 2: faces through the runtime equal the BSP's own (count, corners, planes, texture names,
/// texinfo axes and flags, light fields); Quake 2 textures are external, so none is sized.
#[test]
fn quake2_faces_equal_the_source_bsp_faces() {
    let rels = [
        "q2/e1m1.ericw.bsp",
        "q2/dm2.q2tools.bsp",
        "q2/start.bsp",
        "q2/q2_func_illusionary_visblocker.ericw.bsp",
    ];
    let mut checked = 0;
    for rel in rels {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let world = load::load_bytes(&bytes).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let draw = world.draw();
        let (faces, planes) = q2_faces(&bytes);
        assert!(faces.len() > 100, "{rel}: faces");
        assert_eq!(draw.num_faces(), faces.len(), "{rel}: face count");
        assert!(draw.has_face_draw(), "{rel}: texture projections");
        for (i, f) in faces.iter().enumerate() {
            let face = draw.face(i as u32).expect("face in range");
            assert_eq!(face.vertices, f.corners.as_slice(), "{rel}: face {i} corners");
            let (normal, dist) = planes[f.plane];
            let sign = if f.back { -1.0 } else { 1.0 };
            assert!(
                (face.normal - Vec3A::from_array(normal) * sign).length() < 1e-5,
                "{rel}: face {i} normal"
            );
            assert!((face.dist - dist * sign).abs() < 1e-3, "{rel}: face {i} dist");
            assert_eq!(draw.texture_name(face.texture), Some(f.name.as_str()), "{rel}: face {i} texture");
            assert_eq!(draw.texture_size(face.texture), None, "{rel}: .wal sizes are not in the BSP");
            let d = face.draw.expect("projection");
            assert_eq!(([d.s, d.t], d.flags), (f.axes, f.flags), "{rel}: face {i} texinfo");
            assert_eq!((d.styles, d.light_offset), (f.styles, f.light_offset), "{rel}: face {i} light");
        }
        // The shared Quake 2 maps are not lit (light offsets -1), but every face is textured.
        assert!(faces.iter().all(|f| f.axes != [[0.0; 4]; 2]), "{rel}: texture axes");
        checked += 1;
    }
    if checked == 0 {
        eprintln!("shared Quake 2 maps absent: Quake 2 draw data not compared");
    }
}
