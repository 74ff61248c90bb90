//! Open edges of a triangle soup: edges that belong to one triangle only, where the mesh does not
//! close. Corners are the same when their coordinates are bit for bit equal (`-0.0` is `0.0`), as
//! the corners of an indexed `.obj` are; a T-junction therefore shows up as open edges too.

use std::collections::HashMap;

use glam::DVec3;
use sightline_formats::Aabb;

/// What [`open_edges`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenEdges {
    /// Edges of exactly one triangle.
    pub count: usize,
    /// The box around them (empty when there are none).
    pub bounds: Aabb,
    /// The first of them in triangle order, as its two corners.
    pub first: Option<(DVec3, DVec3)>,
}

type Key = [u64; 3];

fn key(p: DVec3) -> Key {
    // Adding 0.0 turns -0.0 into 0.0, so the two zeros are one corner.
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
}

fn edge(a: DVec3, b: DVec3) -> (Key, Key) {
    let (ka, kb) = (key(a), key(b));
    if ka <= kb { (ka, kb) } else { (kb, ka) }
}

/// The open edges of `triangles`.
pub fn open_edges<'a>(triangles: impl Iterator<Item = &'a [DVec3; 3]> + Clone) -> OpenEdges {
    let mut uses: HashMap<(Key, Key), u32> = HashMap::new();
    let corners = |t: &'a [DVec3; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    for (a, b) in triangles.clone().flat_map(corners) {
        *uses.entry(edge(a, b)).or_default() += 1;
    }
    let mut found = OpenEdges { count: 0, bounds: Aabb::EMPTY, first: None };
    for (a, b) in triangles.flat_map(corners) {
        if uses.get(&edge(a, b)) == Some(&1) {
            found.count += 1;
            found.bounds.add_point(a);
            found.bounds.add_point(b);
            found.first.get_or_insert((a, b));
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quad_has_four_open_edges_and_a_tetrahedron_none() {
        let (a, b, c, d) = (DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
        let quad = [[a, b, c], [a, c, d]];
        let open = open_edges(quad.iter());
        assert_eq!(open.count, 4);
        assert_eq!(open.first, Some((a, b)));
        assert_eq!(open.bounds, Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
        let e = DVec3::new(-0.0, 0.0, 1.0);
        let tetra = [[a, c, b], [a, b, e], [b, c, e], [c, a, DVec3::Z]];
        assert_eq!(open_edges(tetra.iter()).count, 0, "-0.0 and 0.0 are one corner");
    }
}
