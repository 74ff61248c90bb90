//! Target groups, for target sampling: the scene cut once into groups of nearby triangles (the
//! largest BVH subtrees of at most [`TARGET_GROUP`] triangles, see `Bvh::groups`), each with the
//! distinct surface components ([`Components`]) it holds. A cell's target sampling then looks at a
//! group's triangles only when one of its components is unreached, so its cost per cell grows
//! with the number of groups and of components per group, not with the number of triangles
//! (the city's 807 k triangles in one component: 5 ms per cell before, a few µs now).

use sightline_raycast::Bvh;

use super::components::Components;

/// Largest group (BVH subtrees of at most this many triangles).
pub const TARGET_GROUP: usize = 64;

/// The groups of one scene, in the BVH's fixed group order.
#[derive(Debug, Clone, Default)]
pub struct TargetGroups {
    /// Every group's triangles, group after group (each group in BVH build order).
    tris: Vec<u32>,
    /// Group `i`'s triangles are `tris[starts[i]..starts[i + 1]]` (empty when not built).
    starts: Vec<u32>,
    /// Every group's distinct components, ascending, group after group (none without a
    /// component table).
    comps: Vec<u32>,
    /// Group `i`'s components are `comps[comp_starts[i]..comp_starts[i + 1]]`.
    comp_starts: Vec<u32>,
}

impl TargetGroups {
    /// The groups of `bvh`'s triangles with their components in `components` (which may be the
    /// empty table: the groups then list no component). Triangles of no component
    /// ([`Components::NONE`]: non-finite, never in the BVH) are not listed.
    pub fn build(bvh: &Bvh, components: &Components) -> TargetGroups {
        let mut g = TargetGroups { starts: vec![0], comp_starts: vec![0], ..TargetGroups::default() };
        let mut distinct = Vec::new();
        bvh.groups(TARGET_GROUP, |tris| {
            g.tris.extend_from_slice(tris);
            g.starts.push(g.tris.len() as u32);
            if !components.is_empty() {
                distinct.clear();
                distinct.extend(tris.iter().map(|&t| components.of(t)).filter(|&c| c != Components::NONE));
                distinct.sort_unstable();
                distinct.dedup();
                g.comps.extend_from_slice(&distinct);
            }
            g.comp_starts.push(g.comps.len() as u32);
        });
        g
    }

    /// Every group as (its triangles, its distinct components), in order.
    pub fn iter(&self) -> impl Iterator<Item = (&[u32], &[u32])> + '_ {
        let (tris, comps) = (self.starts.windows(2), self.comp_starts.windows(2));
        tris.zip(comps).map(|(t, c)| (run(&self.tris, t), run(&self.comps, c)))
    }

    /// Number of groups (0 when not built).
    pub fn len(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// True when not built (or the scene has no triangle).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// `v[w[0]..w[1]]` for a window `w` of two offsets (empty when out of range).
fn run<'v>(v: &'v [u32], w: &[u32]) -> &'v [u32] {
    match *w {
        [a, b] => v.get(a as usize..b as usize).unwrap_or_default(),
        _ => &[],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn groups_cover_every_triangle_once_with_their_components() {
        let sc = crate::scenegen::spheres(60, true, 5);
        let bvh = Bvh::build(&sc.triangles);
        let comps = Components::build(&sc.triangles);
        let g = TargetGroups::build(&bvh, &comps);
        assert!(g.len() > 1);
        let mut seen = vec![0u32; sc.triangles.len()];
        let mut direct = Vec::new();
        bvh.groups(TARGET_GROUP, |t| direct.push(t.to_vec()));
        assert_eq!(direct.len(), g.len());
        for ((tris, cs), want) in g.iter().zip(&direct) {
            assert_eq!(tris, &want[..]);
            assert!(tris.len() <= TARGET_GROUP);
            let mut expect: Vec<u32> = tris.iter().map(|&t| comps.of(t)).collect();
            expect.sort_unstable();
            expect.dedup();
            assert_eq!(cs, &expect[..]);
            tris.iter().for_each(|&t| seen[t as usize] += 1);
        }
        assert!(seen.iter().all(|&n| n == 1));
        // Without a component table the groups are the same and list no component.
        let bare = TargetGroups::build(&bvh, &Components::default());
        assert!(bare.iter().zip(g.iter()).all(|((a, ca), (b, _))| a == b && ca.is_empty()));
    }

    #[test]
    fn non_finite_triangles_are_left_out() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = [t, [Vec3::NAN, Vec3::X, Vec3::Y], t.map(|p| p + Vec3::Z)];
        let bvh = Bvh::build(&tris);
        let g = TargetGroups::build(&bvh, &Components::build(&tris));
        let all: Vec<(Vec<u32>, Vec<u32>)> = g.iter().map(|(a, b)| (a.to_vec(), b.to_vec())).collect();
        assert_eq!(all.len(), 1);
        let (mut tris, comps) = all[0].clone();
        tris.sort_unstable();
        assert_eq!(tris, vec![0, 2]);
        assert_eq!(comps, vec![0, 1]);
        assert!(TargetGroups::default().is_empty());
    }
}
