//! `sightline validate` on levels our compiler builds from the bundled maps: no misses, and the
//! expected visibility facts hold in the sampled set.

use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_validate::pvs::level_pvs;
use sightline_validate::{Options, OracleChoice, validate};

fn compiled(name: &str) -> sightline_formats::Level {
    let path = sightline_tests::bundled_maps().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let map = sightline_formats::map::parse(&text, name).unwrap_or_else(|e| panic!("{e}"));
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    compile(&Source::Map { map, file: name.to_string() }, &opts, &NoProgress)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .level
}

#[test]
fn bundled_maps_compile_to_a_pvs_without_misses() {
    for name in [
        "two_rooms.map",
        "lbend.map",
        "stairs_pillars.map",
        "thin_leaf.map",
        "coplanar.map",
        "angled.map",
        "detail_water.map",
    ] {
        let level = compiled(name);
        assert!(level.has_vis(), "{name} has a PVS");
        let pvs = level_pvs(&level).unwrap();
        let opts = Options { rays: 400_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &sightline_validate::NoProgress).unwrap();
        eprint!("{name}: {}", v.report.text());
        assert_eq!(v.report.misses(), 0, "{name}: {}", v.report.text());
        assert!(v.report.oracles.iter().all(|o| o.sampled_pairs > 0));
    }
}
