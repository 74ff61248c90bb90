//! The hand-written C header `runtime/capi/include/sightline.h` against the sources of
//! `sightline-capi` (`runtime/capi/src/*.rs`, read as one text, called `ffi.rs` below): every
//! `#[unsafe(no_mangle)] pub ... extern "C" fn` is declared in the header and every `sl_*`
//! declaration of the header is exported, with the same parameter and return types under a small
//! Rust ↔ C type mapping; every `#[repr(C)]` struct has a `typedef struct` with the same fields
//! (names, types, order); every `SL_*` constant has the same value on both sides.

use std::collections::BTreeMap;

/// A function's return type and parameter types, normalised to C spelling.
type Signature = (String, Vec<String>);

/// The text between the `(` at `open` and its matching `)`, and the index after the `)`.
fn parenthesised(text: &str, open: usize) -> Option<(&str, usize)> {
    let mut depth = 0usize;
    for (i, ch) in text[open..].char_indices() {
        match ch {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return Some((&text[open + 1..open + i], open + i + 1));
                }
            }
            _ => {}
        }
    }
    None
}

/// A Rust FFI type in the C spelling of [`c_type`].
fn rust_type(ty: &str) -> String {
    let ty = ty.trim();
    if let Some(inner) = ty.strip_prefix("*const ") {
        return format!("const {} *", rust_type(inner));
    }
    if let Some(inner) = ty.strip_prefix("*mut ") {
        return format!("{} *", rust_type(inner));
    }
    match ty {
        "" | "()" => "void",
        "u8" => "uint8_t",
        "u32" => "uint32_t",
        "u64" => "uint64_t",
        "i32" | "SlStatus" => "int32_t",
        "f32" => "float",
        "usize" => "size_t",
        "c_char" => "char",
        other => other,
    }
    .to_string()
}

/// A C parameter or return type without its name, normalised: `T name[N]` is `T *`, `int` is
/// `int32_t`, tokens joined by single spaces (`const SlWorld *`, `SlWorld * *`).
fn c_type(decl: &str, named: bool) -> String {
    let mut decl = decl.trim().to_string();
    let array = decl.ends_with(']');
    if let Some(i) = decl.find('[') {
        decl.truncate(i);
    }
    let spaced = decl.replace('*', " * ");
    let mut tokens: Vec<&str> = spaced.split_whitespace().collect();
    if named && tokens.len() > 1 && tokens.last().is_some_and(|t| *t != "*") {
        tokens.pop();
    }
    if array {
        tokens.push("*");
    }
    let tokens: Vec<&str> = tokens.into_iter().map(|t| if t == "int" { "int32_t" } else { t }).collect();
    tokens.join(" ")
}

/// The exported functions of `ffi.rs`.
fn rust_functions(src: &str) -> BTreeMap<String, Signature> {
    let mut out = BTreeMap::new();
    for (at, _) in src.match_indices("#[unsafe(no_mangle)]") {
        let rest = &src[at..];
        let fn_at = rest.find("fn ").expect("fn after no_mangle");
        let head = &rest[..fn_at];
        assert!(head.contains("pub ") && head.contains("extern \"C\""), "not `pub extern \"C\"`: {head}");
        let open = rest[fn_at..].find('(').expect("parameters") + fn_at;
        let name = rest[fn_at + 3..open].trim().to_string();
        let (params, after) = parenthesised(rest, open).expect("closed parameters");
        let body = rest[after..].find('{').expect("body") + after;
        let ret = rest[after..body].trim().strip_prefix("->").unwrap_or("");
        let params = params
            .split(',')
            .filter(|p| !p.trim().is_empty())
            .map(|p| rust_type(p.split_once(':').expect("name: type").1))
            .collect();
        out.insert(name, (rust_type(ret), params));
    }
    out
}

/// The `sl_*` function declarations of the header (comments removed).
fn c_functions(header: &str) -> BTreeMap<String, Signature> {
    let text = uncommented(header);
    let mut out = BTreeMap::new();
    for decl in text.split([';', '{', '}']) {
        let Some(open) = decl.find('(') else { continue };
        let head = &decl[..open];
        let Some(name_at) = head.find("sl_") else { continue };
        let name = head[name_at..].trim().to_string();
        let (params, _) = parenthesised(decl, open).expect("closed parameters");
        let params = if params.trim() == "void" {
            Vec::new()
        } else {
            params.split(',').map(|p| c_type(p, true)).collect()
        };
        out.insert(name, (c_type(&head[..name_at], false), params));
    }
    out
}

/// The header without its `/* */` comments.
fn uncommented(header: &str) -> String {
    let mut text = String::new();
    let mut rest = header;
    while let Some(i) = rest.find("/*") {
        text.push_str(&rest[..i]);
        rest = rest[i..].find("*/").map_or("", |j| &rest[i + j + 2..]);
    }
    text.push_str(rest);
    text
}

/// A struct's fields in order: name and type, arrays as `T[N]` (C spelling).
type Fields = Vec<(String, String)>;

/// A Rust field type in C spelling, arrays as `T[N]`.
fn rust_field_type(ty: &str) -> String {
    let ty = ty.trim();
    match ty.strip_prefix('[').and_then(|t| t.strip_suffix(']')).and_then(|t| t.split_once(';')) {
        Some((elem, n)) => format!("{}[{}]", rust_type(elem), n.trim()),
        None => rust_type(ty),
    }
}

/// The `#[repr(C)]` structs of `ffi.rs` (attributes and doc comments between the `repr` and the
/// `struct` skipped).
fn rust_structs(src: &str) -> BTreeMap<String, Fields> {
    let mut out = BTreeMap::new();
    for (at, _) in src.match_indices("#[repr(C)]") {
        let rest = &src[at..];
        let start = rest.find("pub struct ").expect("struct after repr(C)") + "pub struct ".len();
        let open = rest.find('{').expect("struct body");
        let name = rest[start..open].trim().to_string();
        let close = rest.find("\n}").expect("end of struct");
        let fields = rest[open + 1..close]
            .lines()
            .map(str::trim)
            .filter(|l| !l.starts_with("//") && !l.is_empty())
            .map(|l| {
                let (n, ty) = l.strip_prefix("pub ").unwrap_or(l).split_once(':').expect("name: type");
                (n.trim().to_string(), rust_field_type(ty.trim_end_matches(',')))
            })
            .collect();
        out.insert(name, fields);
    }
    out
}

/// The `typedef struct Name { ... } Name;` definitions of the header.
fn c_structs(header: &str) -> BTreeMap<String, Fields> {
    let text = uncommented(header);
    let mut out = BTreeMap::new();
    for (at, _) in text.match_indices("typedef struct ") {
        let rest = &text[at + "typedef struct ".len()..];
        let (Some(open), Some(semi)) = (rest.find('{'), rest.find(';')) else { continue };
        if semi < open {
            continue; // an opaque handle
        }
        let name = rest[..open].trim().to_string();
        let close = rest.find('}').expect("end of struct");
        let fields = rest[open + 1..close]
            .split(';')
            .filter(|d| !d.trim().is_empty())
            .map(|d| {
                let d = d.trim();
                let (decl, array) = match d.split_once('[') {
                    Some((decl, n)) => (decl, format!("[{}]", n.trim_end_matches(']').trim())),
                    None => (d, String::new()),
                };
                let (ty, n) = decl.rsplit_once(char::is_whitespace).expect("type name");
                (n.to_string(), format!("{}{array}", c_type(ty, false)))
            })
            .collect();
        out.insert(name, fields);
    }
    out
}

/// `SL_*` constants of `ffi.rs` (`pub const SL_X: T = value;`).
fn rust_constants(src: &str) -> BTreeMap<String, i64> {
    src.lines()
        .filter_map(|l| l.trim().strip_prefix("pub const SL_"))
        .map(|l| {
            let (name, rest) = l.split_once(':').expect("name: type");
            let value = rest.split_once('=').expect("= value").1.trim().trim_end_matches(';');
            (format!("SL_{name}"), value.parse().expect("an integer literal"))
        })
        .collect()
}

/// `SL_*` enumerators of the header's `enum { ... }` blocks.
fn c_constants(header: &str) -> BTreeMap<String, i64> {
    let text = uncommented(header);
    let mut out = BTreeMap::new();
    for (at, _) in text.match_indices("enum {") {
        let body = &text[at + "enum {".len()..];
        let body = &body[..body.find('}').expect("end of enum")];
        for item in body.split(',').filter(|i| !i.trim().is_empty()) {
            let (name, value) = item.split_once('=').expect("explicit values");
            out.insert(name.trim().to_string(), value.trim().parse().expect("an integer"));
        }
    }
    out
}

/// Every difference between two maps of named items (`what`: "struct", "constant").
fn compare<T: PartialEq + std::fmt::Debug>(
    what: &str,
    c: &BTreeMap<String, T>,
    rust: &BTreeMap<String, T>,
) -> Vec<String> {
    let mut errors = Vec::new();
    for (name, r) in rust {
        match c.get(name) {
            None => errors.push(format!("{what} {name} is in ffi.rs but not in the header")),
            Some(h) if h != r => errors.push(format!("{what} {name}: header {h:?}, ffi.rs {r:?}")),
            Some(_) => {}
        }
    }
    errors.extend(
        c.keys().filter(|n| !rust.contains_key(*n)).map(|n| format!("{what} {n} is in the header only")),
    );
    errors
}

/// Every difference between the header and `ffi.rs`: functions, structs, constants.
fn drift(header: &str, ffi: &str) -> Vec<String> {
    let (c, rust) = (c_functions(header), rust_functions(ffi));
    let mut errors = compare("struct", &c_structs(header), &rust_structs(ffi));
    errors.extend(compare("constant", &c_constants(header), &rust_constants(ffi)));
    for (name, sig) in &rust {
        match c.get(name) {
            None => errors.push(format!("{name} is exported but not declared in the header")),
            Some(h) if h != sig => errors.push(format!("{name}: header {h:?}, ffi.rs {sig:?}")),
            Some(_) => {}
        }
    }
    errors.extend(
        c.keys().filter(|n| !rust.contains_key(*n)).map(|n| format!("{n} is declared but not exported")),
    );
    errors
}

/// The header, and every source file of `sightline-capi` joined in name order.
fn sources() -> (String, String) {
    let root = sightline_tests::workspace_root().join("runtime/capi");
    let read = |p: &std::path::Path| std::fs::read_to_string(p).expect("read source");
    let mut files: Vec<_> = std::fs::read_dir(root.join("src"))
        .expect("runtime/capi/src")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    assert!(files.len() > 1, "{files:?}");
    (read(&root.join("include/sightline.h")), files.iter().map(|p| read(p)).collect::<Vec<_>>().join("\n"))
}

#[test]
fn the_header_declares_exactly_the_exported_functions() {
    let (header, ffi) = sources();
    let errors = drift(&header, &ffi);
    assert!(errors.is_empty(), "sightline.h and ffi.rs disagree:\n{}", errors.join("\n"));
    // The parsers see the functions (a parser finding nothing would agree vacuously).
    let c = c_functions(&header);
    assert!(c.len() >= 25, "{} functions", c.len());
    let s = |t: &str| t.to_string();
    assert_eq!(
        c.get("sl_visible_leaves"),
        Some(&(
            s("int32_t"),
            [
                "const SlWorld *",
                "SlScratch *",
                "const SlCamera *",
                "int32_t",
                "uint32_t *",
                "size_t",
                "size_t *"
            ]
            .map(s)
            .to_vec()
        ))
    );
    assert_eq!(c.get("sl_world_load_file").map(|s| s.1[1].as_str()), Some("SlWorld * *"));
    assert_eq!(c.get("sl_leaf_at").map(|s| s.1[1].as_str()), Some("const float *"));
    assert_eq!(c.get("sl_version"), Some(&(s("const char *"), Vec::new())));
    // The struct and constant parsers see what is there.
    let structs = c_structs(&header);
    assert_eq!(structs.keys().collect::<Vec<_>>(), ["SlCamera", "SlFace", "SlModel", "SlTrace"]);
    let model = &structs["SlModel"];
    assert_eq!(model.first(), Some(&(s("mins"), s("float[3]"))));
    assert_eq!(model.last(), Some(&(s("origin"), s("float[3]"))));
    assert_eq!(
        rust_structs(&ffi)["SlFace"].iter().find(|f| f.0 == "styles"),
        Some(&(s("styles"), s("uint8_t[4]")))
    );
    let constants = c_constants(&header);
    assert_eq!(constants.get("SL_ERR_RANGE"), Some(&6));
    assert_eq!(constants.get("SL_CONTENTS_SKY"), Some(&-6));
    assert_eq!(constants.len(), rust_constants(&ffi).len());
    // The contents constants are the runtime's contents codes.
    use sightline_formats::level::Contents;
    let codes =
        [Contents::Empty, Contents::Solid, Contents::Water, Contents::Slime, Contents::Lava, Contents::Sky]
            .map(|c| i64::from(c.code()));
    let rust = rust_constants(&ffi);
    let named =
        ["EMPTY", "SOLID", "WATER", "SLIME", "LAVA", "SKY"].map(|n| rust[&format!("SL_CONTENTS_{n}")]);
    assert_eq!(codes, named);
}

#[test]
fn drift_is_reported() {
    let (header, ffi) = sources();
    // A renamed declaration: one exported function undeclared, one declaration not exported.
    let renamed = header.replace("sl_world_num_models(", "sl_world_num_modelz(");
    assert_eq!(drift(&renamed, &ffi).len(), 2);
    // A parameter dropped, and a type changed.
    let dropped = header.replace("uint32_t leaf, int32_t *out_contents", "uint32_t leaf");
    assert_eq!(drift(&dropped, &ffi).len(), 1);
    let retyped =
        header.replace("uint32_t leaf, int32_t *out_cluster", "uint64_t leaf, int32_t *out_cluster");
    assert_eq!(drift(&retyped, &ffi).len(), 1);
    // A function exported from Rust only.
    let extra = format!("{ffi}\n#[unsafe(no_mangle)]\npub extern \"C\" fn sl_extra(x: f32) -> u32 {{ 0 }}\n");
    assert_eq!(
        drift(&header, &extra),
        vec!["sl_extra is exported but not declared in the header".to_string()]
    );
    // A struct field retyped, one renamed, two swapped; a field missing from the header.
    let retyped = header.replace(
        "    uint32_t first_face;\n    uint32_t num_faces;",
        "    uint32_t first_face;\n    int32_t num_faces;",
    );
    assert_eq!(drift(&retyped, &ffi).len(), 1, "{:?}", drift(&retyped, &ffi));
    let renamed = header.replace("float near_dist;", "float znear;");
    assert_eq!(drift(&renamed, &ffi).len(), 1);
    let swapped = header.replace(
        "    float yaw;    /* 0 = +X, 90 = +Y */\n    float pitch;",
        "    float pitch;\n    float yaw;",
    );
    assert_eq!(drift(&swapped, &ffi).len(), 1);
    let missing = header.replace("    float origin[3];\n} SlModel;", "} SlModel;");
    assert_eq!(drift(&missing, &ffi), vec![drift(&missing, &ffi)[0].clone()]);
    assert!(drift(&missing, &ffi)[0].starts_with("struct SlModel: header"));
    // A constant changed, and one added to the header only.
    let changed = header.replace("SL_ERR_RANGE = 6", "SL_ERR_RANGE = 7");
    assert_eq!(drift(&changed, &ffi), vec!["constant SL_ERR_RANGE: header 7, ffi.rs 6".to_string()]);
    let added = header.replace("SL_OK = 0,", "SL_OK = 0,\n    SL_ERR_NEW = 9,");
    assert_eq!(drift(&added, &ffi), vec!["constant SL_ERR_NEW is in the header only".to_string()]);
}
