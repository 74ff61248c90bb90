//! Write the heavy benchmark set ([`sightline_tests::heavy`] and the tiny-brush rooms of
//! [`sightline_tests::shapes`]) as `.map` files into a folder, for `tools/heavy_bench.py` or for
//! any compiler:
//!
//! ```sh
//! cargo run --release -p sightline-tests --example heavy_maps -- DIR [NAME_SIZE ...]
//! ```
//!
//! With no names it writes every map of [`SET`]; otherwise only those named (`terrain_24`,
//! `arena_12`, `city_10`, `tiny_1000`, any size). Prints each path written.

use std::process::ExitCode;

use sightline_tests::heavy::{arena, city, terrain};
use sightline_tests::shapes::tiny_brushes_room;

/// The set: each family at sizes growing by about 1.5–2× in map area (or brush count).
const SET: &[&str] = &[
    "terrain_16",
    "terrain_24",
    "terrain_32",
    "arena_8",
    "arena_12",
    "arena_16",
    "city_6",
    "city_9",
    "city_12",
    "tiny_1000",
    "tiny_10000",
];

/// The `.map` text of `name` (`FAMILY_SIZE`), or why not.
fn generate(name: &str) -> Result<String, String> {
    let (family, size) = name.rsplit_once('_').ok_or_else(|| format!("{name}: expected FAMILY_SIZE"))?;
    let n: u32 = size.parse().map_err(|_| format!("{name}: size {size:?} is not a whole number"))?;
    if n == 0 || n > 100_000 {
        return Err(format!("{name}: size must be 1 to 100000"));
    }
    Ok(match family {
        "terrain" => terrain(n, 1),
        "arena" => arena(n),
        "city" => city(n, 1),
        "tiny" => tiny_brushes_room(n, 7),
        _ => return Err(format!("{name}: no family {family:?} (terrain, arena, city, tiny)")),
    })
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((dir, names)) = args.split_first() else {
        eprintln!("usage: heavy_maps DIR [NAME_SIZE ...]");
        return ExitCode::from(2);
    };
    let names: Vec<&str> =
        if names.is_empty() { SET.to_vec() } else { names.iter().map(String::as_str).collect() };
    if let Err(e) = std::fs::create_dir_all(dir) {
        eprintln!("{dir}: {e}");
        return ExitCode::from(2);
    }
    for name in names {
        let path = format!("{dir}/{name}.map");
        match generate(name).and_then(|text| std::fs::write(&path, text).map_err(|e| format!("{path}: {e}")))
        {
            Ok(()) => println!("{path}"),
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::from(2);
            }
        }
    }
    ExitCode::SUCCESS
}
