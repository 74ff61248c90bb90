//! The window (feature `viewer`): fly through a level with PVS culling, or take the stills of
//! `--shots`.
//!
//! The camera starts at the level's `info_player_start` looking along its angle (else at the
//! tour's first stop, [`crate::tour`]). Keys: WASD and the mouse fly (Shift: faster), `C` turns
//! culling off and on, `F` freezes it at the current eye, `P` saves a screenshot
//! (`walk-shot-NNN.png` in the current folder, never over an existing file). The window's title
//! shows the frame time, the level meshes drawn and hidden, the eye's cluster and the culling
//! state.
//!
//! Lighting: one directional light without shadows and an ambient term, so that walls of
//! different orientation read apart; sky and liquids are unlit ([`sightline_bevy::material`]).
//! The camera does not tone-map, so the stills' flat colours are exact ([`crate::shots`]).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use bevy::app::AppExit;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::{PrimaryWindow, WindowResolution};
use sightline_bevy::coords::to_quake;
use sightline_bevy::material::LevelMaterialPlugin;
use sightline_bevy::{
    LevelAsset, LevelRoot, LevelSpawned, PvsCamera, PvsCameraState, SightlinePlugin, Surface,
};
use sightline_validate::render::image::Image as RgbImage;

use crate::shots;
use crate::tour::Tour;
use crate::views;

/// Frames to wait after moving the camera before a still is captured.
const SETTLE_FRAMES: u32 = 20;
/// Captures of one still before it is taken as it is, unsettled (shaders still compiling).
const MAX_CAPTURES: u32 = 60;
/// Seconds between two updates of the window title.
const TITLE_PERIOD: f32 = 0.25;

/// The level being shown.
#[derive(Resource)]
struct Level {
    handle: Handle<LevelAsset>,
    name: String,
}

/// Open the window on `level`; with `shots`, take the stills into that folder and exit.
pub fn run(level: &Path, shots: Option<&Path>) -> ExitCode {
    if let Err(e) = preflight() {
        eprintln!("walk: {e}");
        return ExitCode::from(2);
    }
    let (Some(dir), Some(file)) = (level.parent(), level.file_name()) else {
        eprintln!("walk: {}: not a file path", level.display());
        return ExitCode::from(2);
    };
    let root = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    let name = file.to_string_lossy().into_owned();
    let window = Window {
        title: format!("walk: {name}"),
        resolution: if shots.is_some() {
            WindowResolution::new(640, 480)
        } else {
            WindowResolution::new(1280, 720)
        },
        ..default()
    };
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins
            .set(AssetPlugin { file_path: root.display().to_string(), ..default() })
            .set(WindowPlugin { primary_window: Some(window), ..default() }),
        SightlinePlugin,
        LevelMaterialPlugin,
    ))
    .insert_resource(Level { handle: Handle::default(), name })
    .add_systems(Startup, setup);
    match shots {
        Some(dir) => {
            app.insert_resource(Stills::new(dir.to_path_buf())).add_systems(Update, take_stills);
        }
        None => {
            app.add_systems(Update, (place_camera, fly, keys, title));
        }
    }
    match app.run() {
        AppExit::Success => ExitCode::SUCCESS,
        AppExit::Error(code) => ExitCode::from(code.get()),
    }
}

/// A display and a graphics adapter, or why not (Bevy panics without either).
fn preflight() -> Result<(), String> {
    if std::env::var_os("DISPLAY").is_none() {
        return Err(
            "no X display (DISPLAY is not set): run it on a desktop or under `xvfb-run`, or pass --headless"
                .into(),
        );
    }
    let desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    let backends = desc.backends;
    let instance = wgpu::Instance::new(desc);
    match bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default())) {
        Ok(_) => Ok(()),
        Err(e) => {
            let asked =
                std::env::var("WGPU_BACKEND").map(|b| format!(", WGPU_BACKEND={b}")).unwrap_or_default();
            Err(format!(
                "no graphics adapter ({e}; backends {backends:?}{asked}); this build draws with Vulkan on Linux: \
                 install a Vulkan driver (Mesa's `mesa-vulkan-drivers` has a software one), or pass --headless"
            ))
        }
    }
}

fn setup(mut commands: Commands, assets: Res<AssetServer>, mut level: ResMut<Level>) {
    level.handle = assets.load(level.name.clone());
    commands.spawn(LevelRoot(level.handle.clone()));
    commands.spawn((crate::headless::camera_bundle(), Tonemapping::None, Transform::default()));
    commands.spawn((
        DirectionalLight { illuminance: 2500.0, shadow_maps_enabled: false, ..default() },
        Transform::default().looking_to(Vec3::new(-0.35, -1.0, -0.55), Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight { brightness: 250.0, ..default() });
}

/// The level once its meshes are spawned.
fn loaded<'a>(
    level: &Level,
    levels: &'a Assets<LevelAsset>,
    roots: &Query<(), With<LevelSpawned>>,
) -> Option<&'a LevelAsset> {
    (!roots.is_empty()).then(|| levels.get(&level.handle)).flatten()
}

/// Where the camera starts: the player start, else the tour's first stop.
fn start_pose(asset: &LevelAsset) -> Transform {
    let world = asset.world();
    views::player_start(world).or_else(|| Tour::new(world).transform(0, 1)).unwrap_or_default()
}

/// Put the camera at its start once the level is loaded.
fn place_camera(
    level: Res<Level>,
    levels: Res<Assets<LevelAsset>>,
    roots: Query<(), With<LevelSpawned>>,
    mut placed: Local<bool>,
    mut camera: Query<&mut Transform, With<PvsCamera>>,
) {
    if *placed {
        return;
    }
    let Some(asset) = loaded(&level, &levels, &roots) else { return };
    if let Ok(mut t) = camera.single_mut() {
        *t = start_pose(asset);
        *placed = true;
    }
}

/// WASD + mouse flying.
fn fly(
    keys: Res<ButtonInput<KeyCode>>,
    mouse: Res<AccumulatedMouseMotion>,
    time: Res<Time>,
    mut camera: Query<&mut Transform, With<PvsCamera>>,
) {
    let Ok(mut t) = camera.single_mut() else { return };
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

/// `C` culling off/on, `F` freeze, `P` screenshot.
fn keys(keys: Res<ButtonInput<KeyCode>>, mut commands: Commands, mut camera: Query<&mut PvsCamera>) {
    let Ok(mut pvs) = camera.single_mut() else { return };
    if keys.just_pressed(KeyCode::KeyC) {
        pvs.off = !pvs.off;
        info!("culling {}", if pvs.off { "off" } else { "on" });
    }
    if keys.just_pressed(KeyCode::KeyF) {
        pvs.freeze = !pvs.freeze;
        info!("culling {}", if pvs.freeze { "frozen" } else { "live" });
    }
    if keys.just_pressed(KeyCode::KeyP) {
        let Some(path) =
            (1..1000).map(|n| PathBuf::from(format!("walk-shot-{n:03}.png"))).find(|p| !p.exists())
        else {
            warn!("screenshot: walk-shot-001.png to walk-shot-999.png all exist; nothing saved");
            return;
        };
        commands.spawn(Screenshot::primary_window()).observe(move |shot: On<ScreenshotCaptured>| {
            match shots::to_rgb(&shot.image).map(|rgb| rgb.save(&path)) {
                Some(Ok(())) => info!("screenshot saved to {}", path.display()),
                Some(Err(e)) => error!("screenshot: {e}"),
                None => error!(
                    "screenshot: pixel format {:?} not supported",
                    shot.image.texture_descriptor.format
                ),
            }
        });
    }
}

/// The window title: frame time, meshes drawn and hidden, the eye's cluster, the culling state.
fn title(
    time: Res<Time>,
    level: Res<Level>,
    camera: Query<(&PvsCamera, &PvsCameraState)>,
    mut window: Query<&mut Window, With<PrimaryWindow>>,
    mut smoothed: Local<f32>,
    mut since: Local<f32>,
) {
    let dt = time.delta_secs();
    *smoothed = if *smoothed == 0.0 { dt } else { *smoothed * 0.9 + dt * 0.1 };
    *since += dt;
    if *since < TITLE_PERIOD {
        return;
    }
    *since = 0.0;
    let (Ok((pvs, state)), Ok(mut window)) = (camera.single(), window.single_mut()) else { return };
    let s = state.stats();
    let cluster = s.cluster.map_or("none".to_string(), |c| c.to_string());
    let culling = match (pvs.off, pvs.freeze) {
        (true, _) => "off",
        (false, true) => "frozen",
        (false, false) => "on",
    };
    window.title = format!(
        "walk: {} | {:.2} ms | drawn {} hidden {} | cluster {} | culling {} | WASD+mouse, C culling, F freeze, P screenshot",
        level.name,
        *smoothed * 1000.0,
        s.drawn,
        s.hidden,
        cluster,
        culling
    );
}

/// One still of `--shots`.
struct Still {
    name: &'static str,
    pose: Option<Transform>,
    culling: bool,
}

/// What a still showed.
struct Taken {
    name: &'static str,
    settled: bool,
    counts: shots::Counts,
    drawn: u32,
    hidden: u32,
    cluster: Option<u32>,
    eye: [f32; 3],
}

/// The `--shots` run: the stills, the one being taken, and the last capture of it.
#[derive(Resource)]
struct Stills {
    dir: PathBuf,
    plan: Vec<Still>,
    next: usize,
    /// Frames left before the next capture; `None` while a capture is in flight.
    wait: Option<u32>,
    captures: u32,
    previous: Option<RgbImage>,
    taken: Vec<Taken>,
    missing: Vec<&'static str>,
}

/// The latest capture, handed over by the screenshot observer.
#[derive(Resource, Default)]
struct Captured(Option<Option<RgbImage>>);

impl Stills {
    fn new(dir: PathBuf) -> Self {
        Self {
            dir,
            plan: Vec::new(),
            next: 0,
            wait: Some(SETTLE_FRAMES),
            captures: 0,
            previous: None,
            taken: Vec::new(),
            missing: Vec::new(),
        }
    }

    /// The four stills: the start with culling on and off, and a view of sky and of a liquid.
    fn plan(&mut self, asset: &LevelAsset) {
        let start = start_pose(asset);
        let world = asset.world();
        self.plan = vec![
            Still { name: "start", pose: Some(start), culling: true },
            Still { name: "start-nocull", pose: Some(start), culling: false },
            Still { name: "sky", pose: views::facing(world, Surface::Sky), culling: true },
            Still { name: "liquid", pose: views::facing(world, Surface::Liquid), culling: true },
        ];
    }

    fn json(&self) -> String {
        let shots: Vec<String> = self
            .taken
            .iter()
            .map(|t| {
                format!(
                    "{{\"name\":\"{}\",\"settled\":{},\"sky_pixels\":{},\"liquid_pixels\":{},\"drawn\":{},\"hidden\":{},\"cluster\":{},\"eye\":[{:.1},{:.1},{:.1}]}}",
                    t.name,
                    t.settled,
                    t.counts.sky,
                    t.counts.liquid,
                    t.drawn,
                    t.hidden,
                    t.cluster.map_or("null".to_string(), |c| c.to_string()),
                    t.eye[0],
                    t.eye[1],
                    t.eye[2]
                )
            })
            .collect();
        let missing: Vec<String> = self.missing.iter().map(|m| format!("\"{m}\"")).collect();
        format!("{{\"shots\":[{}],\"not_in_level\":[{}]}}", shots.join(","), missing.join(","))
    }
}

/// Take the stills one after another: pose the camera, let it settle, capture until two captures
/// agree, save, count; exit when done.
#[allow(clippy::too_many_arguments)]
fn take_stills(
    mut commands: Commands,
    level: Res<Level>,
    levels: Res<Assets<LevelAsset>>,
    roots: Query<(), With<LevelSpawned>>,
    mut stills: ResMut<Stills>,
    captured: Local<std::sync::Arc<std::sync::Mutex<Captured>>>,
    mut camera: Query<(&mut Transform, &mut PvsCamera, &PvsCameraState)>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(asset) = loaded(&level, &levels, &roots) else { return };
    let Ok((mut transform, mut pvs, state)) = camera.single_mut() else { return };
    let stills = stills.as_mut();
    if stills.plan.is_empty() {
        stills.plan(asset);
    }
    // Skip stills the level cannot show (no sky, no liquid).
    while let Some(still) = stills.plan.get(stills.next).filter(|s| s.pose.is_none()) {
        stills.missing.push(still.name);
        stills.next += 1;
    }
    let Some(still) = stills.plan.get(stills.next) else {
        println!("{}", stills.json());
        exit.write(AppExit::Success);
        return;
    };
    if let Some(pose) = still.pose {
        *transform = pose;
    }
    pvs.off = !still.culling;
    let image = captured.lock().ok().and_then(|mut c| c.0.take());
    match image {
        // A capture is in flight: the observer fills `captured` a frame or two later.
        None if stills.wait.is_none() => {}
        None => match stills.wait.as_mut() {
            Some(n) if *n > 0 => *n -= 1,
            _ => {
                stills.wait = None;
                let slot = captured.clone();
                commands.spawn(Screenshot::primary_window()).observe(move |shot: On<ScreenshotCaptured>| {
                    if let Ok(mut c) = slot.lock() {
                        c.0 = Some(shots::to_rgb(&shot.image));
                    }
                });
            }
        },
        Some(None) => {
            error!("screenshot: the window's pixel format is not supported");
            exit.write(AppExit::error());
        }
        Some(Some(rgb)) => {
            stills.captures += 1;
            let settled = stills.previous.as_ref().is_some_and(|p| p.pixels == rgb.pixels);
            if !settled && stills.captures < MAX_CAPTURES {
                stills.previous = Some(rgb);
                stills.wait = Some(SETTLE_FRAMES);
                return;
            }
            let path = stills.dir.join(format!("{}.png", still.name));
            if let Err(e) = rgb.save(&path) {
                error!("{e}");
                exit.write(AppExit::error());
                return;
            }
            let s = state.stats();
            let taken = Taken {
                name: still.name,
                settled,
                counts: shots::count(&rgb),
                drawn: s.drawn,
                hidden: s.hidden,
                cluster: s.cluster,
                eye: to_quake(transform.translation),
            };
            stills.taken.push(taken);
            stills.next += 1;
            stills.captures = 0;
            stills.previous = None;
            stills.wait = Some(SETTLE_FRAMES);
        }
    }
}
