//! The hand-written C header `runtime/include/sightline.h` against the exported functions of
//! `runtime/src/ffi.rs`: every `#[unsafe(no_mangle)] pub ... extern "C" fn` is declared in the
//! header and every `sl_*` declaration of the header is exported, with the same parameter and
//! return types under a small Rust ↔ C type mapping.

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
    let mut text = String::new();
    let mut rest = header;
    while let Some(i) = rest.find("/*") {
        text.push_str(&rest[..i]);
        rest = rest[i..].find("*/").map_or("", |j| &rest[i + j + 2..]);
    }
    text.push_str(rest);
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

/// Every difference between the two sets of functions.
fn drift(header: &str, ffi: &str) -> Vec<String> {
    let (c, rust) = (c_functions(header), rust_functions(ffi));
    let mut errors = Vec::new();
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

fn sources() -> (String, String) {
    let root = sightline_tests::workspace_root().join("runtime");
    let read = |p: &str| std::fs::read_to_string(root.join(p)).expect("read source");
    (read("include/sightline.h"), read("src/ffi.rs"))
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
}
