//! The TrenchBroom compile profile `tools/trenchbroom/CompilationProfiles.cfg` is what TrenchBroom
//! reads (version 1, profiles of typed tasks with the keys its parser requires), and its Sightline
//! steps (the tasks run through `${vis}`, TrenchBroom's vis tool set to the `sightline` binary) run
//! as written on a map another compiler built: `vis`, then `validate`, both exit 0.

use std::process::Command;

use serde_json::Value;

/// The keys each task type needs, as TrenchBroom's compilation config parser checks them.
fn required(kind: &str) -> Option<&'static [&'static str]> {
    match kind {
        "export" => Some(&["target"]),
        "copy" | "rename" => Some(&["source", "target"]),
        "delete" => Some(&["target"]),
        "tool" => Some(&["tool", "parameters"]),
        _ => None,
    }
}

#[test]
fn the_trenchbroom_profile_parses_and_its_sightline_steps_run_on_a_compiled_map() {
    let path = sightline_tests::workspace_root().join("tools/trenchbroom/CompilationProfiles.cfg");
    let cfg: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(cfg["version"], 1);
    let profiles = cfg["profiles"].as_array().expect("profiles");
    assert!(!profiles.is_empty());
    let mut steps = Vec::new();
    for profile in profiles {
        assert!(profile["name"].is_string() && profile["workdir"].is_string(), "{profile}");
        for task in profile["tasks"].as_array().expect("tasks") {
            let kind = task["type"].as_str().expect("type");
            let keys = required(kind).unwrap_or_else(|| panic!("unknown task type {kind}"));
            assert!(keys.iter().all(|k| task[k].is_string()), "{task}");
            if task["tool"] == "${vis}" {
                steps
                    .push(task["parameters"].as_str().unwrap_or_default().replace("${MAP_BASE_NAME}", "dm1"));
            }
        }
    }
    assert_eq!(steps, ["vis dm1.bsp", "validate dm1.bsp"]);
    let Some(maps) = sightline_tests::shared_maps() else { return };
    let dir = std::env::temp_dir().join(format!("sightline-tb-profile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["bsp", "prt"] {
        let target = dir.join(format!("dm1.{ext}"));
        std::fs::copy(maps.join(format!("ericw/dm1.{ext}")), &target).unwrap();
        let mut perms = std::fs::metadata(&target).unwrap().permissions();
        #[allow(clippy::permissions_set_readonly_false)]
        perms.set_readonly(false);
        std::fs::set_permissions(&target, perms).unwrap();
    }
    for step in &steps {
        let out = Command::new(sightline_tests::sightline_binary())
            .args(step.split_whitespace())
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "`sightline {step}`: {}", String::from_utf8_lossy(&out.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
