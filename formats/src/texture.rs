//! What a texture name says, as Quake's tools read it: the contents a brush side makes, the
//! ambient sound a face makes, and the tool textures that draw no face. Every rule on texture
//! names lives here (the compiler's brush contents, vis's ambient levels).
//!
//! # Rules
//! On the start of the name, ASCII case-insensitive; the prefixes cannot overlap, so at most one
//! matches:
//! - `*lava…` is lava, `*slime…` slime, any other `*…` water (liquids: see-through);
//! - `sky…` is sky;
//! - `hint…`, `clip…`, `trigger…`, `skip…` and `origin…` are tool textures: no face is drawn;
//! - anything else (the empty name included) is an ordinary, solid surface.
//!
//! What a brush made of several sides becomes (liquid first, then sky, ...) is the compiler's
//! business (`sightline_compiler::contents`), built on [`TextureKind::of`].

use crate::level::Contents;

/// The class of one texture name (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TextureKind {
    /// `*…` other than lava and slime.
    Water,
    /// `*slime…`.
    Slime,
    /// `*lava…`.
    Lava,
    /// `sky…`.
    Sky,
    /// `hint…`: a hint side, a splitter chosen before any other.
    Hint,
    /// `clip…`: player clip, blocks movement only.
    Clip,
    /// `trigger…`: a trigger volume.
    Trigger,
    /// `skip…`: a side that makes no face.
    Skip,
    /// `origin…`: marks a brush entity's rotation origin.
    Origin,
    /// Any other name: a drawn, solid surface.
    Solid,
}

/// Quake's ambient sounds, numbered as the four ambient levels of a BSP leaf (`AMBIENT_*`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Ambient {
    /// Level 0.
    Water = 0,
    /// Level 1.
    Sky = 1,
    /// Level 2.
    Slime = 2,
    /// Level 3.
    Lava = 3,
}

impl Ambient {
    /// Index of this sound in a leaf's four ambient levels.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The sound's name in reports: `water`, `sky`, `slime`, `lava`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Water => "water",
            Self::Sky => "sky",
            Self::Slime => "slime",
            Self::Lava => "lava",
        }
    }
}

/// True when `name` starts with `prefix`, ASCII case-insensitive.
fn starts_with_ignore_case(name: &str, prefix: &str) -> bool {
    name.as_bytes().get(..prefix.len()).is_some_and(|head| head.eq_ignore_ascii_case(prefix.as_bytes()))
}

impl TextureKind {
    /// The class of a texture name.
    pub fn of(name: &str) -> Self {
        if let Some(rest) = name.strip_prefix('*') {
            return if starts_with_ignore_case(rest, "lava") {
                Self::Lava
            } else if starts_with_ignore_case(rest, "slime") {
                Self::Slime
            } else {
                Self::Water
            };
        }
        const TOOLS: [(&str, TextureKind); 6] = [
            ("sky", TextureKind::Sky),
            ("hint", TextureKind::Hint),
            ("clip", TextureKind::Clip),
            ("trigger", TextureKind::Trigger),
            ("skip", TextureKind::Skip),
            ("origin", TextureKind::Origin),
        ];
        TOOLS.iter().find(|(p, _)| starts_with_ignore_case(name, p)).map_or(Self::Solid, |&(_, k)| k)
    }

    /// True for the liquids (`*…`: water, slime, lava), whose faces sight passes through.
    pub fn is_liquid(self) -> bool {
        matches!(self, Self::Water | Self::Slime | Self::Lava)
    }

    /// The contents a side of this texture gives its brush when it is a liquid or sky.
    pub fn contents(self) -> Option<Contents> {
        match self {
            Self::Water => Some(Contents::Water),
            Self::Slime => Some(Contents::Slime),
            Self::Lava => Some(Contents::Lava),
            Self::Sky => Some(Contents::Sky),
            _ => None,
        }
    }

    /// The ambient sound a face of this texture makes, if any.
    pub fn ambient(self) -> Option<Ambient> {
        match self {
            Self::Water => Some(Ambient::Water),
            Self::Sky => Some(Ambient::Sky),
            Self::Slime => Some(Ambient::Slime),
            Self::Lava => Some(Ambient::Lava),
            _ => None,
        }
    }

    /// False for tool textures, whose sides make no drawn face.
    pub fn draws(self) -> bool {
        !matches!(self, Self::Hint | Self::Clip | Self::Trigger | Self::Skip | Self::Origin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quake_texture_names() {
        let of = TextureKind::of;
        assert_eq!(of("*water1"), TextureKind::Water);
        assert_eq!(of("*04water"), TextureKind::Water);
        assert_eq!(of("*sky"), TextureKind::Water);
        assert_eq!(of("*"), TextureKind::Water);
        assert_eq!(of("*SLIME0"), TextureKind::Slime);
        assert_eq!(of("*lava1"), TextureKind::Lava);
        assert_eq!(of("SKY4"), TextureKind::Sky);
        assert_eq!(of("hintskip"), TextureKind::Hint);
        assert_eq!(of("CLIP"), TextureKind::Clip);
        assert_eq!(of("trigger"), TextureKind::Trigger);
        assert_eq!(of("skip"), TextureKind::Skip);
        assert_eq!(of("origin"), TextureKind::Origin);
        assert_eq!(of("sk"), TextureKind::Solid);
        assert_eq!(of("wall5"), TextureKind::Solid);
        assert_eq!(of(""), TextureKind::Solid);
        assert_eq!(of("é*lava"), TextureKind::Solid);
        assert!(!of("SKIP").draws() && !of("origin").draws() && of("sky1").draws() && of("*w").draws());
        assert_eq!(of("*lava").contents(), Some(Contents::Lava));
        assert_eq!(of("sky").contents(), Some(Contents::Sky));
        assert_eq!(of("clip").contents(), None);
    }

    #[test]
    fn ambient_sounds_follow_texture_names() {
        let ambient = |name| TextureKind::of(name).ambient().map(Ambient::index);
        assert_eq!(ambient("*water1"), Some(0));
        assert_eq!(ambient("*04water"), Some(0));
        assert_eq!(ambient("SKY4"), Some(1));
        assert_eq!(ambient("*slime0"), Some(2));
        assert_eq!(ambient("*lava1"), Some(3));
        assert_eq!(ambient("wall5"), None);
        assert_eq!(ambient("skip"), None);
        assert_eq!(ambient(""), None);
    }
}
