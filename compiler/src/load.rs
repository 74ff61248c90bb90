//! From a parsed `.map` to brushes with windings, CSG faces, seeds and the entity text.

use std::collections::HashMap;

use glam::DVec3;

use sightline_formats::geom::WORLD_LIMIT;
use sightline_formats::map::{Entity, MapFile};
use sightline_formats::texture::TextureKind;
use sightline_formats::{Contents, PlaneSet};
use sightline_job::cancel::Cancel;
use sightline_job::progress::{Progress, phase};

use crate::brush::{Brush, BrushProblem, MAX_BRUSH_SIDES, NO_TEXTURE, SideSpec};
use crate::contents::{BrushKind, EntityRole, brush_kind, entity_role};
use crate::csg::{CsgBrush, Surface, clip_faces};
use crate::outside::Seed;

use crate::error::CompileError;
use crate::layers;
use crate::prepared::Prepared;
use crate::report::Stats;
use crate::source::Source;
use crate::viscluster::VisCluster;

/// Class and line of entity `index` (for messages).
pub(crate) fn entity_info(source: &Source, index: usize) -> (String, u32) {
    match source {
        Source::Map { map, .. } => {
            map.entities.get(index).map(|e| (e.classname().to_string(), e.line)).unwrap_or_default()
        }
        Source::Mesh { .. } => (String::new(), 0),
    }
}

fn entity_text(out: &mut String, e: &Entity, model: Option<usize>) {
    out.push_str("{\n");
    for (k, v) in &e.properties {
        if model.is_some() && k == "model" {
            continue;
        }
        out.push_str(&format!("\"{k}\" \"{v}\"\n"));
    }
    if let Some(m) = model {
        out.push_str(&format!("\"model\" \"*{m}\"\n"));
    }
    out.push_str("}\n");
}

/// An `origin` value: exactly three finite numbers separated by white space.
fn parse_origin(text: &str) -> Option<DVec3> {
    let mut it = text.split_whitespace().map(|t| t.parse::<f64>().ok().filter(|v| v.is_finite()));
    let v = DVec3::new(it.next()??, it.next()??, it.next()??);
    it.next().is_none().then_some(v)
}

pub(crate) fn load_map(
    map: &MapFile,
    file: &str,
    progress: &dyn Progress,
    cancel: &Cancel,
) -> Result<Prepared, CompileError> {
    let Some(first) = map.entities.first() else {
        return Err(CompileError::NoEntities { file: file.to_string() });
    };
    if first.classname() != "worldspawn" {
        return Err(CompileError::NoWorldspawn {
            file: file.to_string(),
            line: first.line,
            classname: first.classname().to_string(),
        });
    }
    let omitted = layers::omitted(map);
    if let Some(note) = omitted.note() {
        progress.note(&format!("{file}: {note}"));
    }
    let total: usize = map.entities.iter().map(|e| e.brushes.len()).sum::<usize>() - omitted.brushes;
    let csg = phase(progress, "csg", total as u64);

    let mut planes = PlaneSet::new();
    let mut textures: Vec<String> = Vec::new();
    let mut texture_index: HashMap<String, u32> = HashMap::new();
    let mut surfaces: Vec<Surface> = Vec::new();
    let mut surface_index: HashMap<(u32, [u32; 8]), u32> = HashMap::new();
    let mut world: Vec<CsgBrush> = Vec::new();
    let mut structural: Vec<Brush> = Vec::new();
    // For each entry of `world`, its brush in `structural` (illusionary brushes have none).
    let mut tree_of_world: Vec<Option<usize>> = Vec::new();
    let mut submodels: Vec<Vec<CsgBrush>> = Vec::new();
    let mut seeds = Vec::new();
    let mut entities = String::new();
    let mut stats = Stats { brushes: total, ..Stats::default() };
    let mut visclusters = Vec::new();

    for (ei, e) in map.entities.iter().enumerate() {
        // An entity of a layer omitted from export is not compiled; worldspawn keeps its keys.
        let left_out = omitted.entities.get(ei).copied().unwrap_or(false);
        if left_out && ei > 0 {
            continue;
        }
        let brushes = if left_out { &[][..] } else { &e.brushes[..] };
        let role = entity_role(e.classname(), !e.brushes.is_empty());
        if ei > 0
            && let Some(text) = e.get("origin")
        {
            // A malformed origin would silently drop the entity's seed (a leak going unreported).
            let origin = parse_origin(text).ok_or_else(|| CompileError::BadOrigin {
                file: file.to_string(),
                line: e.line,
                classname: e.classname().to_string(),
                value: text.to_string(),
            })?;
            if origin.abs().max_element() > WORLD_LIMIT {
                return Err(CompileError::HugeCoordinate {
                    file: file.to_string(),
                    line: e.line,
                    what: format!("the origin of `{}`", e.classname()),
                });
            }
            seeds.push(Seed { point: origin, entity: ei });
        }
        let model = match role {
            EntityRole::Submodel => {
                submodels.push(Vec::new());
                Some(submodels.len())
            }
            _ => None,
        };
        if ei == 0 || matches!(role, EntityRole::Submodel | EntityRole::Point) {
            // World, func_group and detail entities merge into the world and leave no text.
            entity_text(&mut entities, e, model);
        }
        if role == EntityRole::VisCluster {
            visclusters.push(VisCluster { line: e.line, brushes: Vec::new() });
        }
        for (bi, b) in brushes.iter().enumerate() {
            csg.advance(1);
            if cancel.is_cancelled() {
                return Err(CompileError::Cancelled { phase: "csg" });
            }
            let bad = |problem: &str| CompileError::BadBrush {
                file: file.to_string(),
                line: b.line,
                entity: ei,
                classname: e.classname().to_string(),
                brush: bi,
                problem: problem.to_string(),
            };
            let shape = |p: BrushProblem| match p {
                BrushProblem::AllDegenerate => bad("every side is degenerate: the planes enclose no volume"),
                BrushProblem::Unbounded => bad(&format!(
                    "the planes do not close the brush, or it reaches beyond ±{WORLD_LIMIT} units"
                )),
            };
            if b.sides.len() > MAX_BRUSH_SIDES {
                return Err(bad(&format!(
                    "{} sides, more than the {MAX_BRUSH_SIDES} a brush may have (the work on one brush grows \
                     with the square of its sides): split it into several brushes",
                    b.sides.len()
                )));
            }
            if role == EntityRole::VisCluster {
                // Not geometry: only its planes, to tell which leaves lie inside.
                if let Some(s) = b
                    .sides
                    .iter()
                    .find(|s| s.points.iter().any(|p| !p.is_finite() || p.abs().max_element() > WORLD_LIMIT))
                {
                    return Err(CompileError::HugeCoordinate {
                        file: file.to_string(),
                        line: s.line,
                        what: format!("a point of entity {ei} (`{}`) brush {bi}", e.classname()),
                    });
                }
                // Its planes must close a volume, as any brush's: an unbounded one would merge
                // leaves far outside what the mapper drew. Checked on planes of its own, so the
                // map's plane set (and the level) stays as without the entity.
                let mut own = PlaneSet::new();
                let specs: Vec<SideSpec> = b
                    .sides
                    .iter()
                    .map(|s| SideSpec { plane: own.insert(s.plane) as u32, hint: false })
                    .collect();
                Brush::from_planes(&own, &specs, Contents::Empty).map_err(shape)?;
                if let Some(v) = visclusters.last_mut() {
                    v.brushes.push(b.sides.iter().map(|s| s.plane).collect());
                }
                continue;
            }
            let kind = brush_kind(b.sides.iter().map(|s| s.texture.as_str()));
            let contents = match kind {
                BrushKind::Contents(c) => c,
                BrushKind::Hint => Contents::Empty,
                BrushKind::Clip | BrushKind::Trigger => continue,
            };
            let mut specs = Vec::with_capacity(b.sides.len());
            for s in &b.sides {
                if s.points.iter().any(|p| !p.is_finite() || p.abs().max_element() > WORLD_LIMIT) {
                    return Err(CompileError::HugeCoordinate {
                        file: file.to_string(),
                        line: s.line,
                        what: format!("a point of entity {ei} (`{}`) brush {bi}", e.classname()),
                    });
                }
                specs.push(SideSpec {
                    plane: planes.insert(s.plane) as u32,
                    hint: TextureKind::of(&s.texture) == TextureKind::Hint,
                });
            }
            let (brush, side_map) = Brush::from_planes(&planes, &specs, contents).map_err(shape)?;
            if brush.sides.len() < 4 {
                stats.warnings.push(format!(
                    "{file}:{}: entity {ei} brush {bi} keeps only {} sides with area; skipped",
                    b.line,
                    brush.sides.len()
                ));
                continue;
            }
            let mut side_surfaces = vec![NO_TEXTURE; brush.sides.len()];
            for (spec_i, s) in b.sides.iter().enumerate() {
                let Some(Some(side_i)) = side_map.get(spec_i) else { continue };
                if kind == BrushKind::Hint || !TextureKind::of(&s.texture).draws() {
                    continue;
                }
                let next = textures.len() as u32;
                let texture = *texture_index.entry(s.texture.clone()).or_insert_with(|| {
                    textures.push(s.texture.clone());
                    next
                });
                let vectors = s.axes.vectors(s.plane.normal).map(|v| v.map(|c| c as f32));
                let key = (texture, std::array::from_fn(|i| vectors[i / 4][i % 4].to_bits()));
                let next = surfaces.len() as u32;
                let surface = *surface_index.entry(key).or_insert_with(|| {
                    surfaces.push(Surface { texture, vectors });
                    next
                });
                if let Some(slot) = side_surfaces.get_mut(*side_i) {
                    *slot = surface;
                }
            }
            match role {
                EntityRole::World => {
                    stats.world_brushes += 1;
                    let mut tree_brush = brush.clone();
                    if kind == BrushKind::Hint {
                        // Only the hint sides of a hint brush split the tree.
                        for s in &mut tree_brush.sides {
                            s.used = !s.hint;
                        }
                    }
                    tree_of_world.push(Some(structural.len()));
                    structural.push(tree_brush);
                    world.push(CsgBrush { brush, surfaces: side_surfaces, model: 0, hides: true });
                }
                EntityRole::Detail => {
                    stats.detail_brushes += 1;
                    // A hint inside func_detail makes no sense: drop it.
                    if kind != BrushKind::Hint {
                        tree_of_world.push(Some(structural.len()));
                        structural.push(Brush { detail: true, ..brush.clone() });
                        world.push(CsgBrush { brush, surfaces: side_surfaces, model: 0, hides: true });
                    }
                }
                EntityRole::Illusionary => {
                    stats.detail_brushes += 1;
                    if kind != BrushKind::Hint {
                        tree_of_world.push(None);
                        world.push(CsgBrush { brush, surfaces: side_surfaces, model: 0, hides: false });
                    }
                }
                EntityRole::Submodel | EntityRole::Point | EntityRole::VisCluster => {
                    let m = submodels.len();
                    if let Some(list) = submodels.last_mut() {
                        list.push(CsgBrush { brush, surfaces: side_surfaces, model: m as u32, hides: true });
                    }
                }
            }
        }
    }
    let world_faces = clip_faces(&planes, &world);
    for f in &world_faces {
        let tree_brush = tree_of_world.get(f.brush as usize).copied().flatten();
        if let Some(b) = tree_brush.and_then(|t| structural.get_mut(t)) {
            for s in &mut b.sides {
                if s.plane == f.plane {
                    s.visible = true;
                }
            }
        }
    }
    stats.submodels = submodels.len();
    let submodels: Vec<(Vec<Brush>, Vec<crate::csg::CsgFace>)> = submodels
        .into_iter()
        .map(|list| {
            let faces = clip_faces(&planes, &list);
            // Hint brushes make no sense in a submodel; empty brushes would only add splits.
            let brushes =
                list.into_iter().map(|c| c.brush).filter(|b| b.contents != Contents::Empty).collect();
            (brushes, faces)
        })
        .collect();
    stats.csg_faces = world_faces.len() + submodels.iter().map(|(_, f)| f.len()).sum::<usize>();
    Ok(Prepared {
        planes,
        structural,
        world_faces,
        submodels,
        seeds,
        entities,
        textures,
        surfaces,
        stats,
        visclusters,
        fill: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CompileOptions, NoProgress, compile};

    #[test]
    fn origins_must_be_three_finite_numbers() {
        assert_eq!(parse_origin(" 1 -2.5\t3e2 "), Some(DVec3::new(1.0, -2.5, 300.0)));
        for bad in ["nan nan nan", "inf 0 0", "0 -inf 0", "1e400 0 0", "abc", "1 2", "", "1 2 3 4", "1 2 x"] {
            assert_eq!(parse_origin(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn a_malformed_origin_is_an_error_with_file_and_line() {
        // A room open to the void whose only point entity has a malformed origin: without the
        // entity's seed the leak would go unreported (an empty level and a warning).
        let room = "( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) wall 0 0 0 1 1\n\
            ( 64 0 0 ) ( 64 0 1 ) ( 64 1 0 ) wall 0 0 0 1 1\n\
            ( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) wall 0 0 0 1 1\n\
            ( 0 64 0 ) ( 1 64 0 ) ( 0 64 1 ) wall 0 0 0 1 1\n\
            ( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) wall 0 0 0 1 1\n\
            ( 0 0 8 ) ( 0 1 8 ) ( 1 0 8 ) wall 0 0 0 1 1\n";
        for value in ["nan nan nan", "inf 0 0", "1e400 0 0", "abc", "1 2", "1 2 3 4", ""] {
            let text = format!(
                "{{\n\"classname\" \"worldspawn\"\n{{\n{room}}}\n}}\n{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{value}\"\n}}\n"
            );
            let map = sightline_formats::map::parse(&text, "o.map").expect("parses");
            let source = Source::Map { map, file: "o.map".into() };
            let err = compile(&source, &CompileOptions::default(), &NoProgress).expect_err(value);
            assert!(matches!(err, CompileError::BadOrigin { line: 12, .. }), "{value:?}: {err}");
            let msg = err.to_string();
            assert!(msg.starts_with("o.map:12:") && msg.contains("info_player_start"), "{msg}");
        }
        // Out of the world is its own error; a good origin still finds the leak.
        for (value, huge) in [("1e30 0 0", true), ("32 32 40", false)] {
            let text = format!(
                "{{\n\"classname\" \"worldspawn\"\n{{\n{room}}}\n}}\n{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{value}\"\n}}\n"
            );
            let map = sightline_formats::map::parse(&text, "o.map").expect("parses");
            let err =
                compile(&Source::Map { map, file: "o.map".into() }, &CompileOptions::default(), &NoProgress)
                    .expect_err(value);
            if huge {
                assert!(matches!(err, CompileError::HugeCoordinate { line: 12, .. }), "{err}");
            } else {
                assert!(matches!(err, CompileError::Leak(_)), "{err}");
            }
        }
    }
}
