//! Pictures of levels: first-person views ([`view`]), plans with PVS, frustum, portals and leak
//! paths ([`plan`]), and PVS matrices ([`matrix`]), written as PNG ([`image`]).

pub mod font;
pub mod image;
pub mod matrix;
pub mod plan;
pub mod view;

use glam::DVec3;

/// Why a picture could not be drawn, or a pointfile read. Pointfile errors start with
/// `file:line:col`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// A pointfile line with fewer than three fields.
    #[error("{file}:{line}:1: expected 3 numbers")]
    PointfileFields {
        /// The pointfile, as named by the caller.
        file: String,
        /// Line (1-based).
        line: usize,
    },
    /// A pointfile field that is not a finite number within ±1e6.
    #[error("{file}:{line}:{col}: coordinate {coordinate} is not a number within ±1e6")]
    PointfileCoordinate {
        /// The pointfile.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column of the field (1-based, in bytes).
        col: usize,
        /// Which coordinate (1 to 3).
        coordinate: usize,
    },
    /// A pointfile line with more than three fields.
    #[error("{file}:{line}:{col}: unexpected `{extra}` after 3 numbers")]
    PointfileExtra {
        /// The pointfile.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column of the extra field (1-based, in bytes).
        col: usize,
        /// The extra field.
        extra: String,
    },
    /// A pointfile without a single point.
    #[error("{file}: no points")]
    PointfileEmpty {
        /// The pointfile.
        file: String,
    },
    /// A view size outside `1..=8192` on either side.
    #[error("image size {width}x{height} is outside 1..=8192")]
    ImageSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// A field of view outside `(0, 179)` degrees.
    #[error("field of view {fov} is outside (0, 179) degrees")]
    FieldOfView {
        /// Requested horizontal field of view in degrees.
        fov: f64,
    },
    /// The eye of a view is in a leaf sight does not pass through.
    #[error("the eye {eye:?} is inside a solid or sky leaf ({leaf})")]
    EyeInSolid {
        /// The eye position.
        eye: [f64; 3],
        /// Its leaf.
        leaf: usize,
    },
    /// The eye of a view is in an open leaf outside every cluster.
    #[error("the eye leaf belongs to no cluster")]
    EyeOutsideClusters,
    /// A plan slab that is not a finite `z0 <= z1`.
    #[error("bad z slab {z0}..{z1}")]
    Slab {
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
    },
    /// A plan width outside `1..=8192`.
    #[error("plan width {width} is outside 1..=8192")]
    PlanWidth {
        /// Requested width.
        width: u32,
    },
    /// No open leaf meets the plan's slab.
    #[error("no open leaf meets the slab z {z0}..{z1}")]
    EmptySlab {
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
    },
}

/// Read a Quake pointfile (`.pts`): one `x y z` point per line, from the leaking entity to the
/// void. Errors name the line and column.
pub fn read_pointfile(text: &str, file: &str) -> Result<Vec<DVec3>, RenderError> {
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        let mut xyz = [0.0f64; 3];
        let mut fields = t.split_whitespace();
        for (i, v) in xyz.iter_mut().enumerate() {
            let f = fields
                .next()
                .ok_or_else(|| RenderError::PointfileFields { file: file.to_string(), line: n + 1 })?;
            let col = f.as_ptr() as usize - line.as_ptr() as usize + 1;
            *v = f.parse().ok().filter(|x: &f64| x.is_finite() && x.abs() <= 1e6).ok_or_else(|| {
                RenderError::PointfileCoordinate {
                    file: file.to_string(),
                    line: n + 1,
                    col,
                    coordinate: i + 1,
                }
            })?;
        }
        if let Some(extra) = fields.next() {
            let col = extra.as_ptr() as usize - line.as_ptr() as usize + 1;
            return Err(RenderError::PointfileExtra {
                file: file.to_string(),
                line: n + 1,
                col,
                extra: extra.to_string(),
            });
        }
        points.push(DVec3::from(xyz));
    }
    if points.is_empty() {
        return Err(RenderError::PointfileEmpty { file: file.to_string() });
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
        assert_eq!(e, "a.pts:2:3: coordinate 2 is not a number within ±1e6");
        let e = read_pointfile("1 2 3 4", "a.pts").unwrap_err().to_string();
        assert_eq!(e, "a.pts:1:7: unexpected `4` after 3 numbers");
        assert!(read_pointfile("1 2 3 4", "a.pts").is_err());
        assert!(read_pointfile("", "a.pts").is_err());
        assert!(read_pointfile("1 2 nan", "a.pts").is_err());
    }
}
