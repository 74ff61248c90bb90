//! The C library as an engine programmer installs it: `tools/install-capi.sh` into a fresh prefix
//! (from the build this test belongs to, `--from target/<profile>`), then a C program built only
//! with `pkg-config --cflags --libs sightline` (shared, with the rpath the install note gives) and
//! with `pkg-config --static` (`cc -static`), run on a vised and an unvised level: both programs
//! load them, and `sl_world_has_pvs` tells them apart.

use std::path::{Path, PathBuf};
use std::process::Command;

use sightline_runtime::load;
use sightline_tests::{bundled_maps, sightline_binary, workspace_root};

const PROGRAM: &str = r#"
#include <stdio.h>
#include "sightline.h"
int main(int argc, char **argv) {
    SlWorld *w = NULL;
    if (argc != 2) return 90;
    if (sl_world_load_file(argv[1], &w) != SL_OK) { fprintf(stderr, "%s\n", sl_last_error()); return 91; }
    printf("%u %u %d\n", sl_world_num_leaves(w), sl_world_num_clusters(w), sl_world_has_pvs(w));
    sl_world_free(w);
    return sl_world_has_pvs(NULL) == 0 ? 0 : 92;
}
"#;

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{cmd:?}: {}\n{stderr}", out.status);
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn compile_level(map: &Path, out: &Path, vis: bool) {
    let mut cmd = Command::new(sightline_binary());
    cmd.arg("compile").arg(map).arg("-o").arg(out);
    if !vis {
        cmd.arg("--no-vis");
    }
    run(&mut cmd);
}

#[test]
fn installed_library_links_by_pkg_config_shared_and_static() {
    let dir = std::env::temp_dir().join(format!("sightline-capi-install-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let prefix = dir.join("prefix");
    // Cargo leaves the libraries it built for this crate's dev-dependency in `deps/`; a build of
    // the package itself leaves them in `target/<profile>`.
    let profile_dir = sightline_binary().parent().expect("target/<profile>").to_path_buf();
    let deps = profile_dir.join("deps");
    let target = if deps.join("libsightline_capi.so").is_file() && deps.join("libsightline_capi.a").is_file()
    {
        deps
    } else {
        profile_dir
    };
    run(Command::new(workspace_root().join("tools/install-capi.sh")).arg(&prefix).arg("--from").arg(&target));
    for f in ["include/sightline.h", "lib/libsightline.so.0", "lib/libsightline.so", "lib/libsightline.a"] {
        assert!(prefix.join(f).exists(), "{f} installed");
    }
    let pc_path = prefix.join("lib/pkgconfig");
    let pkg = |args: &[&str]| -> Vec<String> {
        run(Command::new("pkg-config").args(args).arg("sightline").env("PKG_CONFIG_PATH", &pc_path))
            .split_whitespace()
            .map(str::to_string)
            .collect()
    };
    let libdir = pkg(&["--variable=libdir"]).join("");
    assert_eq!(PathBuf::from(&libdir), prefix.join("lib"));
    let source = dir.join("app.c");
    std::fs::write(&source, PROGRAM).expect("write C");
    let shared = dir.join("app_shared");
    run(Command::new("cc")
        .arg(&source)
        .args(pkg(&["--cflags", "--libs"]))
        .arg(format!("-Wl,-rpath,{libdir}"))
        .arg("-o")
        .arg(&shared));
    let fixed = dir.join("app_static");
    run(Command::new("cc")
        .arg("-static")
        .arg(&source)
        .args(pkg(&["--static", "--cflags", "--libs"]))
        .arg("-o")
        .arg(&fixed));

    let (vised, unvised) = (dir.join("vised.slvl"), dir.join("unvised.slvl"));
    compile_level(&bundled_maps().join("two_rooms.map"), &vised, true);
    compile_level(&bundled_maps().join("two_rooms.map"), &unvised, false);
    for (level, pvs) in [(&vised, 1), (&unvised, 0)] {
        let world = load::load_path(level).expect("load");
        assert_eq!(world.has_vis(), pvs == 1);
        let expected = format!("{} {} {pvs}\n", world.num_leaves(), world.num_clusters());
        for program in [&shared, &fixed] {
            assert_eq!(run(Command::new(program).arg(level)), expected, "{}", program.display());
        }
    }
    std::fs::remove_dir_all(&dir).expect("clean");
}
