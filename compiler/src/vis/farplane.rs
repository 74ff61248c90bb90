//! Far-plane culling (`vis -farplane N`, ericw-tools' `-visdist N`): after vis, clusters farther
//! apart than a distance stop seeing each other, for engines and mods that fog or clip the view
//! at that distance.
//!
//! # Convention
//! - **Conservative within the distance.** Each cluster comes with a box holding every point of
//!   its leaves (see [`crate::visdata::cluster_boxes`] for a Quake map). A pair is hidden only
//!   when the Euclidean distance between the two boxes (the shortest segment from one box to the
//!   other) is strictly greater than the distance; any two points of the clusters are then
//!   farther apart than that, so nothing within the far plane is ever hidden.
//! - Only bits are cleared, never set; both `a → b` and `b → a` are cleared (the matrix stays
//!   symmetric) and every cluster keeps seeing itself.
//! - A box that is empty or holds NaN is taken as unbounded: its cluster is never culled.
//! - [`VisResult::stats`] is recomputed for the culled matrix (visible counts; times and
//!   `avg_mightsee` stay those of the vis run).

use sightline_formats::bits;
use sightline_formats::geom::Aabb;

use super::error::VisError;
use super::stats::VisResult;

/// Distance between two boxes: 0 when they overlap or touch, else the length of the shortest
/// segment between them. `None` when either box is empty or holds NaN (unknown extent).
pub fn box_distance(a: &Aabb, b: &Aabb) -> Option<f64> {
    let known = |x: &Aabb| !x.is_empty() && !x.mins.is_nan() && !x.maxs.is_nan();
    if !known(a) || !known(b) {
        return None;
    }
    // Per axis, the gap between the intervals (0 when they overlap). A box reaching to infinity
    // (an unbounded cluster) gives a zero gap on that axis.
    let gap = (a.mins - b.maxs).max(b.mins - a.maxs).max(glam::DVec3::ZERO);
    Some(gap.length())
}

/// Clears from `result` every pair of distinct clusters whose boxes (`cluster_boxes[c]` for
/// cluster `c`) are farther apart than `distance` (see the module docs). Returns the number of
/// cluster pairs (unordered) cleared.
///
/// Errors when `cluster_boxes` does not have one box per cluster, or `distance` is negative or
/// NaN (an infinite distance culls nothing).
pub fn cull(result: &mut VisResult, cluster_boxes: &[Aabb], distance: f64) -> Result<u64, VisError> {
    let nc = result.num_clusters();
    if cluster_boxes.len() != nc {
        return Err(VisError::Option(format!(
            "far plane: {} cluster boxes for {nc} clusters",
            cluster_boxes.len()
        )));
    }
    if distance.is_nan() || distance < 0.0 {
        return Err(VisError::Option(format!("far plane distance {distance} is not a distance >= 0")));
    }
    let far =
        |a: usize, b: usize| box_distance(&cluster_boxes[a], &cluster_boxes[b]).is_some_and(|d| d > distance);
    let mut pairs = Vec::new();
    for a in 0..nc {
        for b in bits::ones(result.cluster_row(a)) {
            // Each unordered pair once: from the lower cluster, or from the only row holding it.
            if b != a && (a < b || !result.cluster_sees(b, a)) && far(a, b) {
                pairs.push((a, b));
            }
        }
    }
    let words = result.words;
    for &(a, b) in &pairs {
        bits::clear(&mut result.rows[a * words..(a + 1) * words], b);
        bits::clear(&mut result.rows[b * words..(b + 1) * words], a);
    }
    let mut stats = result.stats.clone();
    result.fill_stats(&mut stats);
    result.stats = stats;
    Ok(pairs.len() as u64)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use sightline_formats::geom::Winding;
    use sightline_formats::prt::{PortalFile, PrtPortal};

    use super::*;
    use crate::vis::{self, VisOptions};

    /// Cubes of side 64 in a row along +X (cluster `i` spans `x` in `[64 i, 64 (i + 1)]`), each
    /// pair of neighbours joined by a full 64 × 64 portal: everything sees everything.
    fn row_of_cubes(n: u32) -> (VisResult, Vec<Aabb>) {
        let portals = (1..n)
            .map(|i| {
                let x = 64.0 * f64::from(i);
                let w = Winding::new(vec![
                    DVec3::new(x, 0.0, 0.0),
                    DVec3::new(x, 64.0, 0.0),
                    DVec3::new(x, 64.0, 64.0),
                    DVec3::new(x, 0.0, 64.0),
                ]);
                let w = if w.plane().expect("plane").normal.x < 0.0 { w } else { w.reversed() };
                PrtPortal { leaves: [i - 1, i], winding: w }
            })
            .collect();
        let prt = PortalFile::prt1(n, portals);
        let result = vis::run(
            &prt,
            &VisOptions { threads: 1, ..VisOptions::default() },
            &sightline_job::progress::NoProgress,
        )
        .expect("vis");
        let boxes = (0..n)
            .map(|i| {
                let x = 64.0 * f64::from(i);
                Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 64.0, 64.0, 64.0))
            })
            .collect();
        (result, boxes)
    }

    #[test]
    fn box_distance_is_the_shortest_segment() {
        let unit =
            |x: f64, y: f64, z: f64| Aabb::new(DVec3::new(x, y, z), DVec3::new(x + 1.0, y + 1.0, z + 1.0));
        let a = unit(0.0, 0.0, 0.0);
        assert_eq!(box_distance(&a, &unit(0.5, 0.5, 0.5)), Some(0.0), "overlap");
        assert_eq!(box_distance(&a, &unit(1.0, 0.0, 0.0)), Some(0.0), "touching faces");
        assert_eq!(box_distance(&a, &unit(4.0, 0.0, 0.0)), Some(3.0));
        assert_eq!(box_distance(&unit(4.0, 5.0, 0.0), &a), Some(5.0), "3-4-5 between edges");
        assert_eq!(box_distance(&a, &Aabb::EMPTY), None);
        assert_eq!(box_distance(&Aabb::new(DVec3::NAN, DVec3::ONE), &a), None);
        let everywhere = Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY));
        assert_eq!(box_distance(&everywhere, &a), Some(0.0));
    }

    #[test]
    fn culls_exactly_the_pairs_farther_than_the_plane() {
        let (full, boxes) = row_of_cubes(6);
        assert!((0..6).all(|a| (0..6).all(|b| full.cluster_sees(a, b))), "an open row sees itself whole");
        // Cubes i and j (i < j) are 64 (j - i - 1) apart. A far plane of 64 keeps gaps of 0 and
        // exactly 64 (not farther), hides gaps of 128 and more.
        let mut culled = full.clone();
        let cleared = cull(&mut culled, &boxes, 64.0).expect("cull");
        for a in 0..6usize {
            for b in 0..6usize {
                assert_eq!(culled.cluster_sees(a, b), a.abs_diff(b) <= 2, "{a} -> {b}");
            }
        }
        // Pairs with |i - j| >= 3: (0,3) (0,4) (0,5) (1,4) (1,5) (2,5).
        assert_eq!(cleared, 6);
        assert_eq!(culled.stats.visible_pairs, 36 - 2 * 6);
        assert!(culled.stats.visible_pairs < full.stats.visible_pairs);

        // An unknown box is never culled; an infinite far plane and plane 0 between neighbours
        // hide nothing they should not.
        let mut boxes_unknown = boxes.clone();
        boxes_unknown[0] = Aabb::EMPTY;
        let mut c = full.clone();
        cull(&mut c, &boxes_unknown, 64.0).expect("cull");
        assert!((0..6).all(|b| c.cluster_sees(0, b) && c.cluster_sees(b, 0)));
        let mut c = full.clone();
        assert_eq!(cull(&mut c, &boxes, f64::INFINITY), Ok(0));
        assert_eq!(c, full);
        let mut c = full.clone();
        cull(&mut c, &boxes, 0.0).expect("cull");
        assert!((0..6).all(|a| c.cluster_sees(a, a)), "the diagonal stays");
        assert!((0..5).all(|a| c.cluster_sees(a, a + 1) && c.cluster_sees(a + 1, a)), "touching boxes");
        assert!(!c.cluster_sees(0, 2));

        let mut c = full.clone();
        assert!(matches!(cull(&mut c, &boxes[..5], 64.0), Err(VisError::Option(_))));
        assert!(matches!(cull(&mut c, &boxes, f64::NAN), Err(VisError::Option(_))));
        assert!(matches!(cull(&mut c, &boxes, -1.0), Err(VisError::Option(_))));
        assert_eq!(c, full, "nothing changes on error");
    }
}
