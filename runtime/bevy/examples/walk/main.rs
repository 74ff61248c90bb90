//! Fly through a level with PVS culling.
//!
//! Headless (no window, no GPU; what CI runs): a scripted camera visits the level's open leaves
//! and one JSON object reports the meshes drawn and hidden and the plugin's time per frame:
//!
//! ```text
//! cargo run -p sightline-bevy --features viewer --profile test-opt --example walk -- LEVEL --headless --frames 300 --json
//! ```
//!
//! Windowed (feature `viewer`; see [`viewer`]): the camera starts at `info_player_start`; WASD
//! and the mouse fly, `C` toggles culling, `F` freezes it, `P` saves a screenshot, and the title
//! shows frame time, meshes drawn and hidden and the eye's cluster. `--shots DIR` takes the
//! stills (start with culling on and off, sky, liquid) into `DIR` as PNG, prints one JSON object
//! with their pixel counts, and exits.

mod headless;
#[cfg(feature = "viewer")]
mod shots;
mod tour;
#[cfg(feature = "viewer")]
mod viewer;
#[cfg(feature = "viewer")]
mod views;

use std::path::PathBuf;
use std::process::ExitCode;

struct Args {
    level: PathBuf,
    headless: bool,
    frames: u32,
    json: bool,
    shots: Option<PathBuf>,
}

const USAGE: &str = "usage: walk LEVEL [--headless [--frames N] [--json] | --shots DIR]";

fn parse() -> Result<Args, String> {
    let mut level = None;
    let (mut headless, mut frames, mut json, mut shots) = (false, 300, false, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--headless" => headless = true,
            "--json" => json = true,
            "--frames" => {
                let n = args.next().ok_or("--frames needs a number")?;
                frames = n.parse().map_err(|_| format!("--frames: not a frame count: {n}"))?;
            }
            "--shots" => shots = Some(PathBuf::from(args.next().ok_or("--shots needs a folder")?)),
            "-h" | "--help" => return Err(USAGE.to_string()),
            _ if a.starts_with("--") => return Err(format!("unknown option {a}\n{USAGE}")),
            _ if level.is_none() => level = Some(PathBuf::from(a)),
            _ => return Err(format!("one level only\n{USAGE}")),
        }
    }
    if headless && shots.is_some() {
        return Err(format!("--shots needs the window, not --headless\n{USAGE}"));
    }
    if let Some(dir) = shots.as_ref().filter(|d| !d.is_dir()) {
        return Err(format!("--shots {}: not a folder", dir.display()));
    }
    Ok(Args { level: level.ok_or(USAGE)?, headless, frames, json, shots })
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
        return window(&args);
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

#[cfg(feature = "viewer")]
fn window(args: &Args) -> ExitCode {
    viewer::run(&args.level, args.shots.as_deref())
}

#[cfg(not(feature = "viewer"))]
fn window(_args: &Args) -> ExitCode {
    eprintln!("walk: the window needs `--features viewer`; or pass --headless");
    ExitCode::from(2)
}
