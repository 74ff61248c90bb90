//! Fly through a level with PVS culling.
//!
//! Headless (no window, no GPU; what CI runs): a scripted camera visits the level's open leaves
//! and one JSON object reports the meshes drawn and hidden and the plugin's time per frame:
//!
//! ```text
//! cargo run --release -p sightline-bevy --example walk -- LEVEL --headless --frames 300 --json
//! ```
//!
//! Windowed (build with `--features viewer`): WASD and the mouse fly, `F` freezes culling at the
//! current eye (fly out and look at what was drawn), `F` again resumes.

mod headless;
mod tour;

use std::path::PathBuf;
use std::process::ExitCode;

struct Args {
    level: PathBuf,
    headless: bool,
    frames: u32,
    json: bool,
}

const USAGE: &str = "usage: walk LEVEL [--headless] [--frames N] [--json]";

fn parse() -> Result<Args, String> {
    let mut level = None;
    let (mut headless, mut frames, mut json) = (false, 300, false);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--headless" => headless = true,
            "--json" => json = true,
            "--frames" => {
                let n = args.next().ok_or("--frames needs a number")?;
                frames = n.parse().map_err(|_| format!("--frames: not a frame count: {n}"))?;
            }
            "-h" | "--help" => return Err(USAGE.to_string()),
            _ if a.starts_with("--") => return Err(format!("unknown option {a}\n{USAGE}")),
            _ if level.is_none() => level = Some(PathBuf::from(a)),
            _ => return Err(format!("one level only\n{USAGE}")),
        }
    }
    Ok(Args { level: level.ok_or(USAGE)?, headless, frames, json })
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    if !args.headless {
        return viewer::run(&args.level);
    }
    match headless::walk_file(&args.level, args.frames) {
        Ok(report) if args.json => {
            println!("{}", report.to_json());
            ExitCode::SUCCESS
        }
        Ok(r) => {
            println!(
                "{} frames, {} stops, {} meshes: {:.1} drawn, {:.1} hidden per frame, plugin {:.1} µs per frame",
                r.frames, r.stops, r.meshes, r.drawn_avg, r.hidden_avg, r.system_us_avg
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("walk: {e}");
            ExitCode::from(2)
        }
    }
}

#[cfg(not(feature = "viewer"))]
mod viewer {
    use std::process::ExitCode;

    pub fn run(_level: &std::path::Path) -> ExitCode {
        eprintln!("walk: the window needs `--features viewer`; or pass --headless");
        ExitCode::from(2)
    }
}

#[cfg(feature = "viewer")]
mod viewer {
    use std::process::ExitCode;

    use crate::tour::Tour;
    use bevy::input::mouse::AccumulatedMouseMotion;
    use bevy::prelude::*;
    use sightline_bevy::material::LevelMaterialPlugin;
    use sightline_bevy::{LevelAsset, LevelRoot, PvsCamera, SightlinePlugin};

    #[derive(Resource)]
    struct Level(Handle<LevelAsset>);

    pub fn run(level: &std::path::Path) -> ExitCode {
        let (Some(dir), Some(file)) = (level.parent(), level.file_name()) else {
            eprintln!("walk: {}: not a file path", level.display());
            return ExitCode::from(2);
        };
        let root = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
        let file = file.to_string_lossy().into_owned();
        App::new()
            .add_plugins((
                DefaultPlugins.set(AssetPlugin { file_path: root.display().to_string(), ..default() }),
                SightlinePlugin,
                LevelMaterialPlugin,
            ))
            .add_systems(Startup, move |mut commands: Commands, assets: Res<AssetServer>| {
                let handle = assets.load(file.clone());
                commands.insert_resource(Level(handle.clone()));
                commands.spawn(LevelRoot(handle));
                commands.spawn((
                    crate::headless::camera_bundle(),
                    Transform::default(),
                    PointLight { range: 4096.0, intensity: 4.0e8, ..default() },
                ));
                commands.insert_resource(GlobalAmbientLight { brightness: 400.0, ..default() });
            })
            .add_systems(Update, (place_camera, fly))
            .run();
        ExitCode::SUCCESS
    }

    /// Put the camera at the first stop of the tour once the level is loaded.
    fn place_camera(
        level: Res<Level>,
        levels: Res<Assets<LevelAsset>>,
        mut placed: Local<bool>,
        mut camera: Query<&mut Transform, With<PvsCamera>>,
    ) {
        if *placed {
            return;
        }
        let Some(asset) = levels.get(&level.0) else { return };
        if let (Some(start), Ok(mut t)) = (Tour::new(asset.world()).transform(0, 1), camera.single_mut()) {
            *t = start;
        }
        *placed = true;
    }

    /// WASD + mouse flying; F toggles the freeze.
    fn fly(
        keys: Res<ButtonInput<KeyCode>>,
        mouse: Res<AccumulatedMouseMotion>,
        time: Res<Time>,
        mut camera: Query<(&mut Transform, &mut PvsCamera)>,
    ) {
        let Ok((mut t, mut pvs)) = camera.single_mut() else { return };
        if keys.just_pressed(KeyCode::KeyF) {
            pvs.freeze = !pvs.freeze;
            info!("culling {}", if pvs.freeze { "frozen" } else { "live" });
        }
        let (mut yaw, mut pitch, _) = t.rotation.to_euler(EulerRot::YXZ);
        yaw -= mouse.delta.x * 0.003;
        pitch = (pitch - mouse.delta.y * 0.003).clamp(-1.5, 1.5);
        t.rotation = Quat::from_euler(EulerRot::YXZ, yaw, pitch, 0.0);
        let mut dir = Vec3::ZERO;
        for (key, d) in [
            (KeyCode::KeyW, t.forward().as_vec3()),
            (KeyCode::KeyS, t.back().as_vec3()),
            (KeyCode::KeyA, t.left().as_vec3()),
            (KeyCode::KeyD, t.right().as_vec3()),
        ] {
            if keys.pressed(key) {
                dir += d;
            }
        }
        let speed = if keys.pressed(KeyCode::ShiftLeft) { 1200.0 } else { 320.0 };
        t.translation += dir.normalize_or_zero() * speed * time.delta_secs();
    }
}
