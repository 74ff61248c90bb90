//! Pictures of levels: first-person views ([`view`]), plans with PVS, frustum, portals and leak
//! paths ([`plan`]), and PVS matrices ([`matrix`]), written as PNG ([`image`]).

pub mod image;
pub mod matrix;
pub mod plan;
pub mod view;

use anyhow::{Context, bail};
use glam::DVec3;

/// Read a Quake pointfile (`.pts`): one `x y z` point per line, from the leaking entity to the
/// void. Errors name the line and column.
pub fn read_pointfile(text: &str, file: &str) -> anyhow::Result<Vec<DVec3>> {
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        let mut xyz = [0.0f64; 3];
        let mut fields = t.split_whitespace();
        for (i, v) in xyz.iter_mut().enumerate() {
            let f = fields.next().with_context(|| format!("{file}:{}:1: expected 3 numbers", n + 1))?;
            let col = f.as_ptr() as usize - line.as_ptr() as usize + 1;
            *v = f.parse().ok().filter(|x: &f64| x.is_finite() && x.abs() <= 1e6).with_context(|| {
                format!("{file}:{}:{col}: coordinate {} is not a number within ±1e6", n + 1, i + 1)
            })?;
        }
        if let Some(extra) = fields.next() {
            let col = extra.as_ptr() as usize - line.as_ptr() as usize + 1;
            bail!("{file}:{}:{col}: unexpected `{extra}` after 3 numbers", n + 1);
        }
        points.push(DVec3::from(xyz));
    }
    if points.is_empty() {
        bail!("{file}: no points");
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointfile_reads_and_reports_positions() {
        let p = read_pointfile("0 0 0\n\n 8 -16.5 24\n", "a.pts").unwrap();
        assert_eq!(p, vec![DVec3::ZERO, DVec3::new(8.0, -16.5, 24.0)]);
        let e = read_pointfile("0 0 0\n1 x 2\n", "a.pts").unwrap_err().to_string();
        assert!(e.starts_with("a.pts:2:3:"), "{e}");
        assert!(read_pointfile("1 2 3 4", "a.pts").is_err());
        assert!(read_pointfile("", "a.pts").is_err());
        assert!(read_pointfile("1 2 nan", "a.pts").is_err());
    }
}
