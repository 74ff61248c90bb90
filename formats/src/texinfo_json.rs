//! ericw-tools' `NAME.texinfo.json`: extended texinfo flags its qbsp writes beside `NAME.bsp`
//! (always, since 2.0.0-alpha10) for vis and light to read back.
//!
//! # Layout
//! One JSON object whose keys are texinfo numbers in decimal (`"0"`, `"1"`, …, in any order) and
//! whose values are objects of optional flags, for example
//! `{"0": {}, "4": {"is_special": true, "noambient": true}}`. Texinfos the file leaves out have no
//! extended flags.
//!
//! Vis reads one flag, `noambient` (a `func_group` or brush entity with `"_noambient" "1"`): faces
//! of such a texinfo make no ambient sound. Every other key is light's business and is ignored
//! here, whatever its value.
//!
//! The reader rejects what ericw-tools' own reader cannot take: text that is not JSON, a top
//! level that is not an object, keys that are not texinfo numbers (`0..=u32::MAX`), entries that
//! are not objects, and a `noambient` that is not `true` or `false`. Whether the numbers fit the
//! BSP is the caller's check ([`TexinfoJson::max_texinfo`]; ericw-tools ignores the whole file
//! when one does not). Parsing is `serde_json`'s: no panic, nesting depth capped, memory in
//! proportion to the text.

use std::fmt;

use serde_json::Value;

/// What vis takes from a `NAME.texinfo.json`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TexinfoJson {
    /// Number of texinfo entries in the file.
    pub entries: usize,
    /// The largest texinfo number in the file; `None` when it has no entry.
    pub max_texinfo: Option<u32>,
    /// Texinfo numbers flagged `"noambient": true`, ascending, each once.
    pub noambient: Vec<u32>,
}

impl TexinfoJson {
    /// True when texinfo `texinfo` is flagged `noambient`.
    pub fn is_noambient(&self, texinfo: u32) -> bool {
        self.noambient.binary_search(&texinfo).is_ok()
    }
}

/// What is wrong with a `.texinfo.json`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TexinfoJsonErrorKind {
    /// Not JSON (the message is `serde_json`'s, without its location).
    #[error("invalid JSON: {0}")]
    Syntax(String),
    /// The top level is not an object.
    #[error("expected an object of texinfo entries, found {0}")]
    NotAnObject(&'static str),
    /// A key that is not a texinfo number.
    #[error("key `{0}` is not a texinfo number")]
    BadKey(String),
    /// An entry that is not an object.
    #[error("texinfo {texinfo}: expected an object of flags, found {found}")]
    EntryNotObject {
        /// The texinfo number.
        texinfo: u32,
        /// What the entry is.
        found: &'static str,
    },
    /// A flag vis reads that is not a boolean.
    #[error("texinfo {texinfo}: `{flag}` is {found}, expected true or false")]
    NotABool {
        /// The texinfo number.
        texinfo: u32,
        /// The flag.
        flag: &'static str,
        /// What its value is.
        found: &'static str,
    },
}

/// A `.texinfo.json` read error: `file:line:col: message` for JSON syntax, `file: message` for
/// content that is valid JSON but not texinfo flags.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TexinfoJsonError {
    /// The file, as given to [`read`].
    pub file: String,
    /// 1-based line of a syntax error; 0 when the error has no single place.
    pub line: usize,
    /// 1-based column of a syntax error; 0 when the error has no single place.
    pub col: usize,
    /// What is wrong.
    pub kind: TexinfoJsonErrorKind,
}

impl fmt::Display for TexinfoJsonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}:{}: {}", self.file, self.line, self.col, self.kind)
        } else {
            write!(f, "{}: {}", self.file, self.kind)
        }
    }
}

impl std::error::Error for TexinfoJsonError {}

/// The name ericw-tools gives the side file of `bsp`: its extension replaced by `texinfo.json`
/// (`maps/e1m1.bsp` → `maps/e1m1.texinfo.json`).
pub fn path_beside(bsp: &std::path::Path) -> std::path::PathBuf {
    bsp.with_extension("texinfo.json")
}

/// Longest piece of a hostile key or message quoted in an error.
const QUOTE_MAX: usize = 40;

fn quote(s: &str) -> String {
    match s.char_indices().nth(QUOTE_MAX) {
        Some((end, _)) => format!("{}…", &s[..end]),
        None => s.to_string(),
    }
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// A texinfo number: decimal digits only, within `u32`.
fn texinfo_number(key: &str) -> Option<u32> {
    if key.is_empty() || !key.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    key.parse().ok()
}

/// Reads a `.texinfo.json` from its bytes; `file` names it in errors. A UTF-8 byte order mark is
/// skipped.
pub fn read(bytes: &[u8], file: &str) -> Result<TexinfoJson, TexinfoJsonError> {
    let err = |line, col, kind| TexinfoJsonError { file: file.to_string(), line, col, kind };
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let value: Value = serde_json::from_slice(bytes).map_err(|e| {
        let text = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        let msg = text.strip_suffix(&suffix).unwrap_or(&text);
        err(e.line(), e.column(), TexinfoJsonErrorKind::Syntax(quote(msg)))
    })?;
    let Value::Object(map) = value else {
        return Err(err(0, 0, TexinfoJsonErrorKind::NotAnObject(type_name(&value))));
    };
    let mut out = TexinfoJson { entries: map.len(), ..TexinfoJson::default() };
    for (key, entry) in &map {
        let texinfo =
            texinfo_number(key).ok_or_else(|| err(0, 0, TexinfoJsonErrorKind::BadKey(quote(key))))?;
        out.max_texinfo = out.max_texinfo.max(Some(texinfo));
        let Value::Object(flags) = entry else {
            return Err(err(0, 0, TexinfoJsonErrorKind::EntryNotObject { texinfo, found: type_name(entry) }));
        };
        match flags.get("noambient") {
            None | Some(Value::Bool(false)) => {}
            Some(Value::Bool(true)) => out.noambient.push(texinfo),
            Some(other) => {
                return Err(err(
                    0,
                    0,
                    TexinfoJsonErrorKind::NotABool { texinfo, flag: "noambient", found: type_name(other) },
                ));
            }
        }
    }
    // Keys such as "4" and "04" name one texinfo.
    out.noambient.sort_unstable();
    out.noambient.dedup();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind(text: &str) -> TexinfoJsonErrorKind {
        read(text.as_bytes(), "t.texinfo.json").expect_err("rejected").kind
    }

    #[test]
    fn reads_ericw_qbsp_output() {
        // As ericw-tools' qbsp writes it (tabs, `" : "`, keys sorted as strings).
        let text = "{\n\t\"0\" : {},\n\t\"1\" : {},\n\t\"10\" : \n\t{\n\t\t\"no_shadow\" : true\n\t},\n\
                    \t\"3\" : \n\t{\n\t\t\"is_special\" : true\n\t},\n\t\"4\" : \n\t{\n\t\t\"is_special\" : true,\n\
                    \t\t\"noambient\" : true\n\t}\n}\n";
        let t = read(text.as_bytes(), "m.texinfo.json").expect("valid");
        assert_eq!(t, TexinfoJson { entries: 5, max_texinfo: Some(10), noambient: vec![4] });
        assert!(t.is_noambient(4) && !t.is_noambient(3) && !t.is_noambient(99));
        let empty = read(b"\xEF\xBB\xBF{ }", "e").expect("a BOM and no entries");
        assert_eq!(empty, TexinfoJson::default());
        let both =
            read(br#"{"7": {"noambient": true}, "07": {"noambient": true}, "2": {"noambient": false}}"#, "x")
                .expect("valid");
        assert_eq!(both.noambient, vec![7]);
    }

    #[test]
    fn hostile_text_is_an_error_naming_the_file() {
        let e = read(b"{\n  \"0\": {,\n}", "maps/bad.texinfo.json").expect_err("syntax");
        assert_eq!((e.line, e.col > 0), (2, true));
        let shown = e.to_string();
        assert!(shown.starts_with("maps/bad.texinfo.json:2:"), "{shown}");
        assert!(!shown.contains(" at line "), "the location is given once: {shown}");
        assert!(matches!(kind("[1, 2]"), TexinfoJsonErrorKind::NotAnObject("an array")));
        assert!(matches!(kind(r#"{"-1": {}}"#), TexinfoJsonErrorKind::BadKey(_)));
        assert!(matches!(kind(r#"{"4294967296": {}}"#), TexinfoJsonErrorKind::BadKey(_)));
        assert!(matches!(kind(r#"{" 1": {}}"#), TexinfoJsonErrorKind::BadKey(_)));
        assert!(matches!(kind(r#"{"1": 5}"#), TexinfoJsonErrorKind::EntryNotObject { texinfo: 1, .. }));
        assert!(matches!(
            kind(r#"{"2": {"noambient": 1}}"#),
            TexinfoJsonErrorKind::NotABool { texinfo: 2, flag: "noambient", found: "a number" }
        ));
        let long = format!("{{\"{}\": {{}}}}", "9".repeat(10_000));
        let TexinfoJsonErrorKind::BadKey(k) = kind(&long) else { panic!("bad key") };
        assert!(k.chars().count() <= QUOTE_MAX + 1, "quoted keys are short");
        // Deep nesting stops at serde_json's depth limit instead of overflowing the stack.
        let deep = format!("{{\"0\": {{\"x\": {}{}}}}}", "[".repeat(100_000), "]".repeat(100_000));
        assert!(matches!(kind(&deep), TexinfoJsonErrorKind::Syntax(_)));
        for bytes in [&b""[..], b"\xff\xfe", b"{\"0\": {}} trailing", b"{\"0\": {\"noambient\": tru"] {
            let e = read(bytes, "f.json").expect_err("rejected");
            assert!(e.to_string().starts_with("f.json:"), "{e}");
        }
    }

    proptest::proptest! {
        /// Any bytes, and any mutation of a valid file, read or fail without panicking.
        #[test]
        fn never_panics(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..256),
                        at in 0usize..64, byte in proptest::prelude::any::<u8>()) {
            let _ = read(&bytes, "p.json");
            let mut valid = br#"{"0": {}, "4": {"is_special": true, "noambient": true}}"#.to_vec();
            let at = at % valid.len();
            valid[at] = byte;
            let _ = read(&valid, "p.json");
        }
    }
}
