//! A Bevy app without window or GPU ([`app`]) and the scripted walk through a level that the
//! `walk` example, CI and the plugin's tests (`tests/culling.rs`, which include this file) run
//! ([`walk_file`]).
//!
//! The app has Bevy's task pools, assets, meshes, transforms and cameras (with their visibility
//! systems) and [`SightlinePlugin`]: everything the culling needs, nothing that renders. The walk
//! spawns the level at the identity, one [`PvsCamera`] with a 90° perspective and a far plane
//! beyond any Quake level, moves it along a [`Tour`] and reads [`CullStats`] after each frame.

use std::path::Path;
use std::time::{Duration, Instant};

use bevy::app::{App, TaskPoolPlugin};
use bevy::asset::{AssetPlugin, AssetServer, Assets, Handle, LoadState};
use bevy::camera::{Camera3d, CameraPlugin, PerspectiveProjection, Projection};
use bevy::ecs::prelude::*;
use bevy::mesh::MeshPlugin;
use bevy::transform::TransformPlugin;
use bevy::transform::components::Transform;

use crate::tour::Tour;
use sightline_bevy::{ClusterMesh, CullStats, LevelAsset, LevelRoot, PvsCamera, PvsCulled, SightlinePlugin};

/// Longest wait for a level to load through the asset server.
const LOAD_TIMEOUT: Duration = Duration::from_secs(120);

/// What a walk measured, per frame on average over its frames.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WalkReport {
    /// Frames run.
    pub frames: u32,
    /// Stops of the tour (open leaves it can stand in).
    pub stops: u32,
    /// The level's entities: cluster meshes and brush models.
    pub meshes: u32,
    /// Frames in which the eye had a cluster (the PVS was used).
    pub culled_frames: u32,
    /// The level's entities left in the camera's visible list.
    pub drawn_avg: f64,
    /// The level's entities removed from it by the plugin.
    pub hidden_avg: f64,
    /// Leaves in the PVS and the frustum.
    pub leaves_avg: f64,
    /// The plugin's time: leaf update plus culling, microseconds.
    pub system_us_avg: f64,
    /// Of which the culling system.
    pub cull_us_avg: f64,
}

impl WalkReport {
    /// One JSON object (no trailing newline).
    pub fn to_json(self) -> String {
        format!(
            "{{\"frames\":{},\"stops\":{},\"meshes\":{},\"culled_frames\":{},\"drawn_avg\":{:.3},\"hidden_avg\":{:.3},\"leaves_avg\":{:.3},\"system_us_avg\":{:.3},\"cull_us_avg\":{:.3}}}",
            self.frames,
            self.stops,
            self.meshes,
            self.culled_frames,
            self.drawn_avg,
            self.hidden_avg,
            self.leaves_avg,
            self.system_us_avg,
            self.cull_us_avg
        )
    }
}

/// Why a walk could not run.
#[derive(Debug, thiserror::Error)]
pub enum WalkError {
    /// The level did not load (the loader's message names the file).
    #[error("{0}")]
    Load(String),
    /// The level has no open leaf to stand in.
    #[error("{0}: the level has no open leaf to walk through")]
    NoOpenLeaf(String),
}

/// A headless app with the plugin; see the module docs. `asset_root` is the folder the asset
/// server reads from.
pub fn app(asset_root: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        TaskPoolPlugin::default(),
        AssetPlugin { file_path: asset_root.display().to_string(), ..Default::default() },
        MeshPlugin,
        TransformPlugin,
        CameraPlugin,
        SightlinePlugin,
    ));
    app
}

/// A camera for the walk and the tests: 90° vertical field of view, far plane at 65,536 units.
pub fn camera_bundle() -> impl Bundle {
    (
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: std::f32::consts::FRAC_PI_2,
            far: 65536.0,
            ..Default::default()
        }),
        PvsCamera::default(),
    )
}

/// Load `path` (a `.bsp` or `.slvl`) through the asset server and walk `frames` frames.
pub fn walk_file(path: &Path, frames: u32) -> Result<WalkReport, WalkError> {
    let name = path.display().to_string();
    let (Some(dir), Some(file)) = (path.parent(), path.file_name()) else {
        return Err(WalkError::Load(format!("{name}: not a file path")));
    };
    let dir = std::path::absolute(dir).map_err(|e| WalkError::Load(format!("{name}: {e}")))?;
    let mut app = app(&dir);
    let handle: Handle<LevelAsset> =
        app.world().resource::<AssetServer>().load(file.to_string_lossy().into_owned());
    let start = Instant::now();
    loop {
        app.update();
        match app.world().resource::<AssetServer>().load_state(&handle) {
            LoadState::Loaded => break,
            // The first line: Bevy appends a backtrace to loader errors.
            LoadState::Failed(e) => {
                return Err(WalkError::Load(e.to_string().lines().next().unwrap_or_default().to_string()));
            }
            _ if start.elapsed() > LOAD_TIMEOUT => {
                return Err(WalkError::Load(format!("{name}: not loaded after {LOAD_TIMEOUT:?}")));
            }
            _ => std::thread::sleep(Duration::from_millis(1)),
        }
    }
    run(app, handle, &name, frames)
}

fn run(mut app: App, handle: Handle<LevelAsset>, name: &str, frames: u32) -> Result<WalkReport, WalkError> {
    let tour = {
        let levels = app.world().resource::<Assets<LevelAsset>>();
        let level = levels.get(&handle).ok_or_else(|| WalkError::Load(format!("{name}: not loaded")))?;
        Tour::new(level.world())
    };
    let first = tour.transform(0, frames).ok_or_else(|| WalkError::NoOpenLeaf(name.to_string()))?;
    app.world_mut().spawn(LevelRoot(handle));
    let camera = app.world_mut().spawn((camera_bundle(), first)).id();
    // Spawn the level's meshes and let Bevy compute their bounds.
    app.update();
    let meshes = {
        let world = app.world_mut();
        let clusters = world.query::<&ClusterMesh>().iter(world).count();
        let culled = world.query_filtered::<(), With<PvsCulled>>().iter(world).count();
        (clusters + culled) as u32
    };
    let mut report = WalkReport { frames, stops: tour.len() as u32, meshes, ..Default::default() };
    let (mut drawn, mut hidden, mut leaves, mut system, mut cull) = (0u64, 0u64, 0u64, 0.0, 0.0);
    for frame in 0..frames {
        let pose: Transform = tour.transform(frame, frames).unwrap_or(first);
        if let Some(mut t) = app.world_mut().get_mut::<Transform>(camera) {
            *t = pose;
        }
        app.update();
        let stats = *app.world().resource::<CullStats>();
        let view =
            app.world().get::<sightline_bevy::PvsCameraState>(camera).map(|s| s.stats()).unwrap_or_default();
        drawn += u64::from(stats.drawn);
        hidden += u64::from(stats.hidden);
        leaves += u64::from(view.leaves);
        report.culled_frames += u32::from(view.culled);
        system += (stats.leaves_time + stats.cull_time).as_secs_f64() * 1e6;
        cull += stats.cull_time.as_secs_f64() * 1e6;
    }
    let n = f64::from(frames.max(1));
    report.drawn_avg = drawn as f64 / n;
    report.hidden_avg = hidden as f64 / n;
    report.leaves_avg = leaves as f64 / n;
    report.system_us_avg = system / n;
    report.cull_us_avg = cull / n;
    Ok(report)
}
