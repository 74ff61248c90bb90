//! TrenchBroom layers left out of export: what of a `.map` is not compiled.
//!
//! TrenchBroom saves its layers and groups in the `.map` itself:
//!
//! - a **layer** is a `func_group` with `"_tb_type" "_tb_layer"`, `"_tb_name"` and `"_tb_id"`,
//!   holding the layer's world brushes; the default layer is `worldspawn` itself;
//! - a **group** is a `func_group` with `"_tb_type" "_tb_group"` and `"_tb_id"`, holding its world
//!   brushes;
//! - an entity or group in a layer other than the default one has `"_tb_layer" "<layer id>"`; a
//!   member of a group has `"_tb_group" "<group id>"` instead (groups nest, and a nested group's
//!   layer is its outermost group's).
//!
//! A layer (or `worldspawn`, for the default layer) with `"_tb_layer_omit_from_export" "1"` is left
//! out of TrenchBroom's own export, so it is left out of the compile too: its brushes, and every
//! entity and group in it (with their members, however deep), are not in the BSP, seed nothing and
//! cannot leak. `worldspawn`'s keys are always kept. A `_tb_layer` or `_tb_group` naming no layer or
//! group, or groups that name each other in a loop, count as the default layer, as TrenchBroom
//! reads them. Other `func_group`s are merged into the world as ever.

use std::collections::HashMap;

use sightline_formats::map::{Entity, MapFile};

const TYPE: &str = "_tb_type";
const LAYER_TYPE: &str = "_tb_layer";
const GROUP_TYPE: &str = "_tb_group";
const ID: &str = "_tb_id";
const NAME: &str = "_tb_name";
const IN_LAYER: &str = "_tb_layer";
const IN_GROUP: &str = "_tb_group";
const OMIT: &str = "_tb_layer_omit_from_export";

/// What a map's omitted layers leave out.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Omitted {
    /// For each entity of the map: its brushes (and, but for `worldspawn`, the entity itself) are
    /// left out.
    pub entities: Vec<bool>,
    /// Brushes left out.
    pub brushes: usize,
    /// Entities left out, not counting the layers' and groups' own `func_group`s.
    pub entity_count: usize,
    /// Names of the omitted layers, in map order.
    pub layers: Vec<String>,
}

impl Omitted {
    /// What to tell the user, when anything is left out.
    pub fn note(&self) -> Option<String> {
        (!self.layers.is_empty()).then(|| {
            let names: Vec<String> = self.layers.iter().map(|n| format!("\"{n}\"")).collect();
            format!(
                "left out {} brushes and {} entities of {} {} omitted from export ({OMIT}): {}",
                self.brushes,
                self.entity_count,
                self.layers.len(),
                if self.layers.len() == 1 { "layer" } else { "layers" },
                names.join(", ")
            )
        })
    }
}

fn tb_type(e: &Entity) -> Option<&str> {
    (e.classname() == "func_group").then(|| e.get(TYPE)).flatten()
}

fn omitted_flag(e: &Entity) -> bool {
    e.get(OMIT).is_some_and(|v| v.trim() == "1")
}

/// Where an entity or group sits: in a group, in a layer, or in the default layer.
#[derive(Clone, Copy)]
enum Parent {
    Group(usize),
    Layer(bool),
    Default,
}

/// Which entities of `map` lie in layers omitted from export.
pub(crate) fn omitted(map: &MapFile) -> Omitted {
    let mut layers: HashMap<&str, bool> = HashMap::new();
    let mut groups: HashMap<&str, usize> = HashMap::new();
    let mut names = Vec::new();
    let default_omitted = map.entities.first().is_some_and(omitted_flag);
    if default_omitted {
        names.push("Default Layer".to_string());
    }
    for (i, e) in map.entities.iter().enumerate() {
        let Some(id) = e.get(ID).map(str::trim) else { continue };
        match tb_type(e) {
            Some(LAYER_TYPE) if !layers.contains_key(id) => {
                layers.insert(id, omitted_flag(e));
                if omitted_flag(e) {
                    names.push(e.get(NAME).unwrap_or(id).to_string());
                }
            }
            Some(GROUP_TYPE) => {
                groups.entry(id).or_insert(i);
            }
            _ => {}
        }
    }
    let parent = |e: &Entity| {
        if let Some(&g) = e.get(IN_GROUP).and_then(|id| groups.get(id.trim())) {
            Parent::Group(g)
        } else if let Some(&omit) = e.get(IN_LAYER).and_then(|id| layers.get(id.trim())) {
            Parent::Layer(omit)
        } else {
            Parent::Default
        }
    };
    // Groups resolved so far, and for each group the entity whose resolution last met it (a group
    // met twice while resolving one entity is a loop).
    let mut group_omitted: Vec<Option<bool>> = vec![None; map.entities.len()];
    let mut met_by: Vec<usize> = vec![usize::MAX; map.entities.len()];
    let mut entities = vec![false; map.entities.len()];
    let mut out = Omitted::default();
    for (i, e) in map.entities.iter().enumerate() {
        let omit = match (i, tb_type(e)) {
            (0, _) => default_omitted,
            (_, Some(LAYER_TYPE)) => omitted_flag(e),
            _ => {
                let mut chain = Vec::new();
                let mut at = parent(e);
                let omit = loop {
                    match at {
                        Parent::Layer(omit) => break omit,
                        Parent::Default => break default_omitted,
                        Parent::Group(g) => {
                            if let Some(known) = group_omitted[g] {
                                break known;
                            }
                            if met_by[g] == i {
                                break default_omitted;
                            }
                            met_by[g] = i;
                            chain.push(g);
                            at = parent(&map.entities[g]);
                        }
                    }
                };
                for g in chain {
                    group_omitted[g] = Some(omit);
                }
                omit
            }
        };
        if omit {
            entities[i] = true;
            out.brushes += e.brushes.len();
            if i > 0 && tb_type(e).is_none_or(|t| t != LAYER_TYPE && t != GROUP_TYPE) {
                out.entity_count += 1;
            }
        }
    }
    out.entities = entities;
    out.layers = names;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entity(pairs: &[(&str, &str)], brushes: usize) -> String {
        let mut s = String::from("{\n");
        for (k, v) in pairs {
            s.push_str(&format!("\"{k}\" \"{v}\"\n"));
        }
        for _ in 0..brushes {
            s.push_str(
                "{\n( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) a 0 0 0 1 1\n( 8 0 0 ) ( 8 0 1 ) ( 8 1 0 ) a 0 0 0 1 1\n\
                 ( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) a 0 0 0 1 1\n( 0 8 0 ) ( 1 8 0 ) ( 0 8 1 ) a 0 0 0 1 1\n\
                 ( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) a 0 0 0 1 1\n( 0 0 8 ) ( 0 1 8 ) ( 1 0 8 ) a 0 0 0 1 1\n}\n",
            );
        }
        s.push_str("}\n");
        s
    }

    fn parse(entities: &[String]) -> MapFile {
        sightline_formats::map::parse(&entities.concat(), "layers.map").expect("parses")
    }

    const LAYER: (&str, &str) = ("_tb_type", "_tb_layer");
    const GROUP: (&str, &str) = ("_tb_type", "_tb_group");
    const FUNC_GROUP: (&str, &str) = ("classname", "func_group");

    #[test]
    fn an_omitted_layer_leaves_out_its_brushes_entities_and_nested_groups() {
        let map = parse(&[
            entity(&[("classname", "worldspawn")], 2),
            // 1: an omitted layer with one brush; 2: a kept one.
            entity(&[FUNC_GROUP, LAYER, ("_tb_name", "gone"), ("_tb_id", "3"), (OMIT, "1")], 1),
            entity(&[FUNC_GROUP, LAYER, ("_tb_name", "kept"), ("_tb_id", "4"), (OMIT, "0")], 1),
            // 3: a light in the omitted layer; 4: one in the kept layer; 5: one in the default.
            entity(&[("classname", "light"), ("_tb_layer", "3")], 0),
            entity(&[("classname", "light"), ("_tb_layer", "4")], 0),
            entity(&[("classname", "light")], 0),
            // 6: a group in the omitted layer, 7: a group in it, 8: an entity in that, 9: a door.
            entity(&[FUNC_GROUP, GROUP, ("_tb_id", "10"), ("_tb_layer", "3")], 1),
            entity(&[FUNC_GROUP, GROUP, ("_tb_id", "11"), ("_tb_group", "10")], 2),
            entity(&[("classname", "info_null"), ("_tb_group", "11")], 0),
            entity(&[("classname", "func_door"), ("_tb_group", "11")], 1),
            // 10: a group in the kept layer with a member; 12: a plain func_group.
            entity(&[FUNC_GROUP, GROUP, ("_tb_id", "12"), ("_tb_layer", "4")], 1),
            entity(&[("classname", "light"), ("_tb_group", "12")], 0),
            entity(&[FUNC_GROUP], 1),
        ]);
        let out = omitted(&map);
        let left_out: Vec<usize> = (0..map.entities.len()).filter(|&i| out.entities[i]).collect();
        assert_eq!(left_out, [1, 3, 6, 7, 8, 9]);
        assert_eq!((out.brushes, out.entity_count), (1 + 1 + 2 + 1, 3));
        assert_eq!(out.layers, ["gone"]);
        assert_eq!(
            out.note().as_deref(),
            Some(
                "left out 5 brushes and 3 entities of 1 layer omitted from export (_tb_layer_omit_from_export): \"gone\""
            )
        );
    }

    #[test]
    fn nothing_is_left_out_without_an_omitted_layer() {
        let map = parse(&[
            entity(&[("classname", "worldspawn")], 1),
            entity(&[FUNC_GROUP, LAYER, ("_tb_name", "a"), ("_tb_id", "1")], 1),
            entity(&[("classname", "light"), ("_tb_layer", "1")], 0),
        ]);
        let out = omitted(&map);
        assert!(out.entities.iter().all(|&o| !o));
        assert_eq!(out.note(), None);
    }

    #[test]
    fn unknown_ids_and_group_loops_are_the_default_layer() {
        for default_omitted in [false, true] {
            let mut world = vec![("classname", "worldspawn")];
            if default_omitted {
                world.push((OMIT, "1"));
            }
            let map = parse(&[
                entity(&world, 1),
                entity(&[FUNC_GROUP, LAYER, ("_tb_name", "gone"), ("_tb_id", "1"), (OMIT, "1")], 0),
                entity(&[("classname", "light"), ("_tb_layer", "99")], 0),
                entity(&[("classname", "light"), ("_tb_group", "98")], 0),
                entity(&[FUNC_GROUP, GROUP, ("_tb_id", "5"), ("_tb_group", "6")], 1),
                entity(&[FUNC_GROUP, GROUP, ("_tb_id", "6"), ("_tb_group", "5")], 1),
                entity(&[("classname", "light"), ("_tb_group", "6")], 0),
            ]);
            let out = omitted(&map);
            assert_eq!(
                out.entities,
                [
                    default_omitted,
                    true,
                    default_omitted,
                    default_omitted,
                    default_omitted,
                    default_omitted,
                    default_omitted
                ]
            );
            let names: Vec<&str> = out.layers.iter().map(String::as_str).collect();
            if default_omitted {
                assert_eq!(names, ["Default Layer", "gone"]);
                assert_eq!((out.brushes, out.entity_count), (3, 3), "worldspawn's brush and the groups'");
            } else {
                assert_eq!(names, ["gone"]);
                assert_eq!((out.brushes, out.entity_count), (0, 0));
            }
        }
    }

    #[test]
    fn deeply_nested_groups_follow_their_outermost_group() {
        // Groups nested 3000 deep, listed innermost first, the outermost in the omitted layer.
        let depth = 3000;
        let mut entities = vec![
            entity(&[("classname", "worldspawn")], 0),
            entity(&[FUNC_GROUP, LAYER, ("_tb_name", "gone"), ("_tb_id", "1"), (OMIT, "1")], 0),
            entity(&[("classname", "light"), ("_tb_group", &format!("g{depth}"))], 0),
        ];
        for k in (1..=depth).rev() {
            let (id, parent) = (format!("g{k}"), format!("g{}", k - 1));
            let within = if k == 1 { ("_tb_layer", "1") } else { ("_tb_group", parent.as_str()) };
            entities.push(entity(&[FUNC_GROUP, GROUP, ("_tb_id", &id), within], 0));
        }
        let out = omitted(&parse(&entities));
        assert!(!out.entities[0]);
        assert!(out.entities[1..].iter().all(|&o| o));
        assert_eq!((out.brushes, out.entity_count), (0, 1));
    }
}
