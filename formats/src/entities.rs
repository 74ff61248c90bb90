//! Quake entity text: the entity lump of a BSP (and [`crate::level::Level::entities`]), a list of
//! `{ "key" "value" ... }` blocks without brushes.
//!
//! # Rules
//! Tokens follow Quake's tokenizer (`crate::lexer`, shared with the `.map` parser): any byte up
//! to `' '` separates tokens, `//` at the start of a token comments out the rest of the line, and
//! a quoted string runs to the next `"` on the same line, with no escapes. Keys and values may be
//! quoted or bare words (as Quake's `ED_ParseEdict` reads them); a bare `{` or `}` is structure.
//! Any other character is allowed in a string, high-bit ones included (Quake's coloured text: the
//! BSP readers turn the lump into text byte for byte where it is UTF-8, with U+FFFD elsewhere).
//! A key may repeat; [`Entity::get`] returns the last value, as Quake does.
//!
//! # Errors
//! Every [`EntityError`] names the byte offset in the text where it was found; origins that are
//! not three finite numbers are an error of [`Entity::origin`], not of [`parse`], so one bad key
//! does not hide the other entities.

use thiserror::Error;

use crate::lexer::{Lexer, Token};

/// One entity: its key/value pairs in text order.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Entity {
    /// Key/value pairs in text order (repeats kept).
    pub pairs: Vec<(String, String)>,
    /// Byte offset of its `{` in the text.
    pub offset: usize,
}

/// A malformed entity text or value; offsets are bytes from the start of the text.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum EntityError {
    /// Something other than `{` where an entity should start.
    #[error("byte {offset}: expected `{{` to open an entity, found {found:?}")]
    ExpectedOpen {
        /// Where the token starts.
        offset: usize,
        /// The token.
        found: String,
    },
    /// A quoted string without its closing quote on the same line.
    #[error("byte {offset}: unterminated quoted string")]
    Unterminated {
        /// Where the opening quote is.
        offset: usize,
    },
    /// The text ends inside an entity.
    #[error("byte {offset}: the entity opened here is not closed before the end of the text")]
    Unclosed {
        /// Where its `{` is.
        offset: usize,
    },
    /// A key followed by `}` or `{` instead of its value.
    #[error("byte {offset}: key {key:?} has no value")]
    MissingValue {
        /// Where the key starts.
        offset: usize,
        /// The key.
        key: String,
    },
    /// A `{` inside an entity (brushes do not belong in entity text).
    #[error("byte {offset}: `{{` inside an entity (entity text has no brushes)")]
    Nested {
        /// Where the `{` is.
        offset: usize,
    },
    /// An `origin` value that is not three finite numbers.
    #[error("byte {offset}: the entity's origin {value:?} is not three finite numbers")]
    BadOrigin {
        /// Where the entity's `{` is.
        offset: usize,
        /// The value.
        value: String,
    },
}

impl Entity {
    /// The value of `key` (the last one when repeated, as Quake does).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.pairs.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The `classname`, or `""`.
    pub fn classname(&self) -> &str {
        self.get("classname").unwrap_or("")
    }

    /// The `origin` key: `None` without one, an error unless it is exactly three finite numbers
    /// separated by whitespace.
    pub fn origin(&self) -> Option<Result<[f32; 3], EntityError>> {
        let value = self.get("origin")?;
        let mut numbers = value.split_whitespace().map(|t| t.parse::<f32>().ok().filter(|v| v.is_finite()));
        let parsed = match (numbers.next(), numbers.next(), numbers.next(), numbers.next()) {
            (Some(Some(x)), Some(Some(y)), Some(Some(z)), None) => Some([x, y, z]),
            _ => None,
        };
        Some(parsed.ok_or_else(|| EntityError::BadOrigin { offset: self.offset, value: value.to_string() }))
    }

    /// The brush model of a brush entity: `N` for `"model" "*N"`; `None` without a model key or
    /// for a model file (`"progs/player.mdl"`) or a malformed number.
    pub fn model(&self) -> Option<u32> {
        self.get("model")?.strip_prefix('*')?.parse().ok()
    }
}

/// Parse entity text into entities in text order.
pub fn parse(text: &str) -> Result<Vec<Entity>, EntityError> {
    let mut lx = Lexer::new(text);
    let mut out = Vec::new();
    while let Some(open) = next(&mut lx)? {
        if !is(&open, "{") {
            return Err(EntityError::ExpectedOpen { offset: open.offset, found: open.text.to_string() });
        }
        let mut entity = Entity { pairs: Vec::new(), offset: open.offset };
        loop {
            let Some(key) = next(&mut lx)? else {
                return Err(EntityError::Unclosed { offset: open.offset });
            };
            if is(&key, "}") {
                break;
            }
            if is(&key, "{") {
                return Err(EntityError::Nested { offset: key.offset });
            }
            let value = match next(&mut lx)? {
                Some(v) if !is(&v, "}") && !is(&v, "{") => v,
                Some(_) => {
                    return Err(EntityError::MissingValue { offset: key.offset, key: key.text.to_string() });
                }
                None => return Err(EntityError::Unclosed { offset: open.offset }),
            };
            entity.pairs.push((key.text.to_string(), value.text.to_string()));
        }
        out.push(entity);
    }
    Ok(out)
}

/// The next token, an unterminated string as an [`EntityError`].
fn next<'a>(lx: &mut Lexer<'a>) -> Result<Option<Token<'a>>, EntityError> {
    lx.next_token().map_err(|u| EntityError::Unterminated { offset: u.offset })
}

/// True when `t` is the bare word `word` (a quoted `"}"` is a string).
fn is(t: &Token<'_>, word: &str) -> bool {
    !t.quoted && t.text == word
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_pairs_comments_and_high_bit_text() {
        let text = "// header\n{\n\"classname\" \"worldspawn\"\n\"message\" \"\u{e9}\u{fffd} x\"\n}\n\
                    { classname func_door \"model\" \"*3\" \"origin\" \"1 -2.5 3e2\" \"model\" \"*4\" }\n";
        let ents = parse(text).unwrap();
        assert_eq!(ents.len(), 2);
        assert_eq!(ents[0].classname(), "worldspawn");
        assert_eq!(ents[0].get("message"), Some("\u{e9}\u{fffd} x"));
        assert_eq!(ents[0].offset, text.find('{').unwrap());
        assert_eq!(ents[1].classname(), "func_door");
        // The last of a repeated key wins; the pairs keep both, in order.
        assert_eq!(ents[1].model(), Some(4));
        assert_eq!(ents[1].pairs.iter().filter(|(k, _)| k == "model").count(), 2);
        assert_eq!(ents[1].origin(), Some(Ok([1.0, -2.5, 300.0])));
        assert_eq!(ents[0].origin(), None);
        assert_eq!(ents[0].model(), None);
        assert_eq!(parse("").unwrap(), Vec::new());
        assert_eq!(parse("{ \"}\" \"{\" }").unwrap()[0].get("}"), Some("{"), "quoted braces are strings");
    }

    #[test]
    fn origins_must_be_three_finite_numbers() {
        for bad in ["1 2", "1 2 3 4", "1 nan 3", "inf 0 0", "1 2 x", "", "1e40 0 0"] {
            let e = parse(&format!("  {{ \"origin\" \"{bad}\" }}")).unwrap().remove(0);
            assert_eq!(e.origin(), Some(Err(EntityError::BadOrigin { offset: 2, value: bad.to_string() })));
        }
        let e = parse("{ \"model\" \"progs/player.mdl\" }").unwrap().remove(0);
        assert_eq!(e.model(), None);
        let e = parse("{ \"model\" \"*x\" }").unwrap().remove(0);
        assert_eq!(e.model(), None);
    }

    #[test]
    fn errors_name_the_byte_offset() {
        let err = |t: &str| parse(t).unwrap_err();
        assert_eq!(err("{ } x"), EntityError::ExpectedOpen { offset: 4, found: "x".into() });
        assert_eq!(err("{ \"a\" \"b\" "), EntityError::Unclosed { offset: 0 });
        assert_eq!(err(" { \"a\" "), EntityError::Unclosed { offset: 1 });
        assert_eq!(err("{ \"a\" }"), EntityError::MissingValue { offset: 2, key: "a".into() });
        assert_eq!(err("{ \"a\" \"b\n\" }"), EntityError::Unterminated { offset: 6 });
        assert_eq!(err("{ { } }"), EntityError::Nested { offset: 2 });
        let shown = err("{ { } }").to_string();
        assert!(shown.starts_with("byte 2:"), "{shown}");
    }
}
