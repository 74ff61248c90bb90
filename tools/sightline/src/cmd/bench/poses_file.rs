//! The saved-poses file of `sightline bench --poses-file` / `--save-poses`: plain text, one camera
//! pose a line.
//!
//! # Format
//! Each pose is a line of five numbers separated by whitespace, `X Y Z YAW PITCH`: the eye in world
//! units, yaw in degrees from +x towards +y, pitch in degrees, positive up (the optics are
//! [`Camera::quake`]'s: 90° horizontal field of view at 4:3). Blank lines and lines starting with
//! `#` are ignored; text after a `#` on a pose line is a comment. Every number must be finite. A
//! file with no pose, or more than [`MAX_POSES`], is an error, as is any other line; errors name the
//! file and the line (1-based). Numbers are written in Rust's shortest round-trip form, so a saved
//! file reads back to exactly the same `f32` poses.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, bail};
use glam::Vec3;
use sightline_runtime::Camera;

/// Most poses a file may hold (the protocol times every backend on each).
pub const MAX_POSES: usize = 10_000;

/// One saved pose and its comment (the text after `#` on its line, trimmed; may be empty).
#[derive(Debug, Clone, PartialEq)]
pub struct Pose {
    /// The camera ([`Camera::quake`] at the eye, yaw and pitch).
    pub camera: Camera,
    /// What the line's comment says (e.g. `occluded`), empty without one.
    pub label: String,
}

/// Read the poses of `path` (see the module docs).
pub fn read(path: &Path) -> anyhow::Result<Vec<Pose>> {
    let file = path.display();
    // A regular file only, as every input (a FIFO or a device is refused, not opened).
    let bytes = sightline_job::input::read_input(path).context("cannot read the poses file")?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!("{file}: the poses file is not UTF-8 text (byte {})", e.utf8_error().valid_up_to())
    })?;
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let (data, comment) = line.split_once('#').unwrap_or((line, ""));
        if data.trim().is_empty() {
            continue;
        }
        let at = || format!("{file}: line {}", i + 1);
        let nums: Vec<&str> = data.split_whitespace().collect();
        if nums.len() != 5 {
            bail!("{}: expected five numbers `X Y Z YAW PITCH`, found {} fields", at(), nums.len());
        }
        let mut v = [0f32; 5];
        for (slot, s) in v.iter_mut().zip(&nums) {
            *slot = s
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .with_context(|| format!("{}: `{s}` is not a finite number", at()))?;
        }
        if poses.len() == MAX_POSES {
            bail!("{}: more than {MAX_POSES} poses", at());
        }
        poses.push(Pose {
            camera: Camera::quake(Vec3::new(v[0], v[1], v[2]), v[3], v[4]),
            label: comment.trim().to_string(),
        });
    }
    if poses.is_empty() {
        bail!("{file}: no pose in the poses file (lines of `X Y Z YAW PITCH`)");
    }
    Ok(poses)
}

/// The text of a poses file holding `poses` (see the module docs), with a header comment.
pub fn write(poses: &[Pose]) -> String {
    let mut s = String::from(
        "# sightline bench poses: X Y Z YAW PITCH (world units; degrees, yaw from +x to +y, pitch up)\n",
    );
    for p in poses {
        let c = &p.camera;
        let _ = write!(s, "{} {} {} {} {}", c.position.x, c.position.y, c.position.z, c.yaw, c.pitch);
        if !p.label.is_empty() {
            let _ = write!(s, " # {}", p.label.replace('\n', " "));
        }
        s.push('\n');
    }
    s
}
