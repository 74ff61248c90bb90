//! What a brush is made of, decided from its texture names as Quake's tools do, and what an entity
//! contributes to the level.
//!
//! Each side's name is classified by [`sightline_formats::texture`], which owns the name rules
//! (and which sides draw no face). Over all sides of a brush, the first match wins:
//! - a liquid side (`*lava…` lava, `*slime…` slime, any other `*…` water) makes that liquid (the
//!   first liquid side decides);
//! - a `sky…` side makes sky (drawn as sky; opaque to sight, so no portal joins sky to anything
//!   else; the outside flood stops at it);
//! - a `hint…` side makes a hint brush: not solid, its hint sides are splitters chosen before any
//!   other;
//! - a brush of `clip…` sides (and `skip…` ones) blocks movement only, so it makes no faces and
//!   does not block sight;
//! - a brush of `trigger…` sides (and `skip…` ones) is a trigger volume: no faces, not solid;
//! - anything else is solid (`origin…` sides count as ordinary sides here).

use sightline_formats::Contents;
use sightline_formats::texture::TextureKind;

/// The kind of a brush, from its textures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BrushKind {
    /// Fills its leaves with these contents and draws faces.
    Contents(Contents),
    /// A hint brush: splits the tree with its hint sides, otherwise empty.
    Hint,
    /// Player clip: neither faces nor sight blocking.
    Clip,
    /// Trigger volume: neither faces nor sight blocking.
    Trigger,
}

/// The kind of a brush with sides textured `textures`.
pub(crate) fn brush_kind<'a, I: IntoIterator<Item = &'a str>>(textures: I) -> BrushKind {
    let (mut liquid, mut sky, mut hint, mut clip, mut trigger, mut other) =
        (None, false, false, false, false, false);
    for t in textures {
        match TextureKind::of(t) {
            k @ (TextureKind::Water | TextureKind::Slime | TextureKind::Lava) => {
                liquid = liquid.or(k.contents());
            }
            TextureKind::Sky => sky = true,
            TextureKind::Hint => hint = true,
            TextureKind::Clip => clip = true,
            TextureKind::Trigger => trigger = true,
            TextureKind::Skip => {}
            TextureKind::Origin | TextureKind::Solid => other = true,
        }
    }
    if let Some(c) = liquid {
        BrushKind::Contents(c)
    } else if sky {
        BrushKind::Contents(Contents::Sky)
    } else if hint {
        BrushKind::Hint
    } else if clip && !other {
        BrushKind::Clip
    } else if trigger && !other {
        BrushKind::Trigger
    } else {
        BrushKind::Contents(Contents::Solid)
    }
}

/// Priority when several brushes share a leaf: the highest wins.
pub(crate) fn priority(c: Contents) -> u8 {
    match c {
        Contents::Empty => 0,
        Contents::Water => 1,
        Contents::Slime => 2,
        Contents::Lava => 3,
        Contents::Sky => 4,
        Contents::Solid => 5,
    }
}

/// True when sight passes between two adjacent leaves of these contents, so that a portal joins
/// them: neither is solid, and sky meets only sky (a sky surface hides what lies behind it, as
/// Quake's tools write no portal into sky). Liquids are see-through, as ericw-tools' default.
pub(crate) fn sight_passes(a: Contents, b: Contents) -> bool {
    sight_passes_with(a, b, LiquidSight::Transparent)
}

/// Whether a liquid surface lets sight through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LiquidSight {
    /// Water, slime and lava are see-through (ericw-tools' qbsp, `-transwater`).
    #[default]
    Transparent,
    /// A liquid surface blocks sight: only leaves of equal contents are joined (id's qbsp).
    Opaque,
}

/// As [`sight_passes`], with liquids see-through or not as `liquids` says: under
/// [`LiquidSight::Opaque`] a portal joins only non-solid leaves of the same contents.
pub(crate) fn sight_passes_with(a: Contents, b: Contents, liquids: LiquidSight) -> bool {
    match liquids {
        LiquidSight::Transparent => {
            a != Contents::Solid && b != Contents::Solid && (a == Contents::Sky) == (b == Contents::Sky)
        }
        LiquidSight::Opaque => a == b && a != Contents::Solid,
    }
}

/// True for contents that stop the outside flood (solid rock and sky, as Quake's qbsp).
pub(crate) fn blocks_outside(c: Contents) -> bool {
    matches!(c, Contents::Solid | Contents::Sky)
}

/// What an entity's brushes become.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum EntityRole {
    /// `worldspawn` and `func_group`: structural world brushes.
    World,
    /// `func_detail` family: drawn world brushes that split the tree only after the structural
    /// ones (their leaves share clusters); they seal the world like structural brushes.
    Detail,
    /// `func_detail_illusionary`: drawn world faces only; not in the tree, not solid, no seal.
    Illusionary,
    /// Any other entity with brushes: its own submodel.
    Submodel,
    /// A point entity.
    Point,
    /// `func_viscluster`: its brushes only mark leaves to merge into one cluster for vis.
    VisCluster,
}

/// The class name of the clustering volume ([`EntityRole::VisCluster`], `crate::viscluster`).
pub(crate) const VISCLUSTER_CLASSNAME: &str = "func_viscluster";

/// The role of an entity by class name and whether it has brushes.
pub(crate) fn entity_role(classname: &str, has_brushes: bool) -> EntityRole {
    match classname {
        "worldspawn" | "func_group" => EntityRole::World,
        "func_detail" | "func_detail_wall" | "func_detail_fence" => EntityRole::Detail,
        "func_detail_illusionary" => EntityRole::Illusionary,
        VISCLUSTER_CLASSNAME => EntityRole::VisCluster,
        _ if has_brushes => EntityRole::Submodel,
        _ => EntityRole::Point,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quake_texture_rules() {
        assert_eq!(brush_kind(["*lava1", "*lava1"]), BrushKind::Contents(Contents::Lava));
        assert_eq!(brush_kind(["*slime0"]), BrushKind::Contents(Contents::Slime));
        assert_eq!(brush_kind(["*04water1", "wall"]), BrushKind::Contents(Contents::Water));
        assert_eq!(brush_kind(["sky4", "wall"]), BrushKind::Contents(Contents::Sky));
        assert!(sight_passes(Contents::Empty, Contents::Water));
        assert!(sight_passes(Contents::Sky, Contents::Sky));
        assert!(!sight_passes(Contents::Empty, Contents::Sky));
        assert!(!sight_passes(Contents::Lava, Contents::Solid));
        let opaque = |a, b| sight_passes_with(a, b, LiquidSight::Opaque);
        assert!(!opaque(Contents::Empty, Contents::Water) && !opaque(Contents::Water, Contents::Slime));
        assert!(opaque(Contents::Water, Contents::Water) && opaque(Contents::Sky, Contents::Sky));
        assert!(!opaque(Contents::Solid, Contents::Solid));
        assert_eq!(brush_kind(["CLIP", "clip"]), BrushKind::Clip);
        assert_eq!(brush_kind(["trigger"]), BrushKind::Trigger);
        assert_eq!(brush_kind(["hint", "skip"]), BrushKind::Hint);
        assert_eq!(brush_kind(["wbrick1_5", "skip"]), BrushKind::Contents(Contents::Solid));
        assert_eq!(brush_kind(["clip", "origin"]), BrushKind::Contents(Contents::Solid));
        assert_eq!(brush_kind(["trigger", "skip"]), BrushKind::Trigger);
        assert_eq!(brush_kind(["*lava1", "*slime"]), BrushKind::Contents(Contents::Lava));
    }

    #[test]
    fn entity_roles() {
        assert_eq!(entity_role("func_group", true), EntityRole::World);
        assert_eq!(entity_role("func_detail", true), EntityRole::Detail);
        assert_eq!(entity_role("func_detail_illusionary", true), EntityRole::Illusionary);
        assert_eq!(entity_role("func_door", true), EntityRole::Submodel);
        assert_eq!(entity_role("light", false), EntityRole::Point);
        assert_eq!(entity_role("func_viscluster", true), EntityRole::VisCluster);
        assert_eq!(entity_role("func_viscluster", false), EntityRole::VisCluster);
    }
}
