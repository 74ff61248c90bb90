//! The visible set of a cluster as a BVH: the faces of every leaf in the clusters its PVS row
//! names, built on first use and cached per cluster.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use sightline_raycast::Bvh;

use super::scene::LevelScene;
use crate::pvs::BitMatrix;

/// A cluster's PVS set: its triangles (scene numbering, ascending) in a BVH of their own.
#[derive(Debug)]
pub struct CellSet {
    /// The eye cluster.
    pub cluster: u32,
    /// Scene triangle of each of the set's triangles (the BVH's build order).
    pub triangles: Vec<u32>,
    /// Faces in the set.
    pub faces: usize,
    /// The BVH over the set's triangles.
    pub bvh: Bvh,
    /// Time to gather the set (the PVS row's clusters, their leaves' faces, their triangles).
    pub gather: Duration,
    /// Time to build its BVH.
    pub bvh_build: Duration,
}

impl CellSet {
    /// Gather the faces of every leaf whose cluster `pvs` row `cluster` names (world faces only),
    /// and build their BVH.
    pub fn build(scene: &LevelScene<'_>, pvs: &BitMatrix, cluster: u32) -> CellSet {
        let start = Instant::now();
        let tree = scene.tree();
        let level = tree.level();
        let mut marked = vec![false; level.faces.len()];
        for (l, leaf) in level.leaves.iter().enumerate() {
            let seen = tree.cluster(l).is_some_and(|c| {
                (c as usize) < pvs.len()
                    && (cluster as usize) < pvs.len()
                    && pvs.get(cluster as usize, c as usize)
            });
            if !seen {
                continue;
            }
            let first = leaf.first_face as usize;
            for &f in
                level.leaf_faces.get(first..first.saturating_add(leaf.num_faces as usize)).unwrap_or_default()
            {
                if let Some(m) = marked.get_mut(f as usize) {
                    *m = true;
                }
            }
        }
        let mut triangles = Vec::new();
        let mut faces = 0;
        for (f, _) in marked.iter().enumerate().filter(|(_, m)| **m) {
            let r = scene.face_triangles(f);
            faces += usize::from(!r.is_empty());
            triangles.extend(r);
        }
        let soup: Vec<_> = triangles.iter().map(|&t| scene.triangles()[t as usize]).collect();
        let gather = start.elapsed();
        let start = Instant::now();
        let bvh = Bvh::build(&soup);
        CellSet { cluster, triangles, faces, bvh, gather, bvh_build: start.elapsed() }
    }

    /// Time to gather the set and build its BVH.
    pub fn build_time(&self) -> Duration {
        self.gather + self.bvh_build
    }

    /// Bytes the set holds on the heap (its BVH and triangle map).
    pub fn heap_bytes(&self) -> usize {
        self.bvh.heap_bytes() + size_of_val(self.triangles.as_slice())
    }
}

/// Cluster sets built so far, by cluster.
#[derive(Debug, Default)]
pub struct CellCache {
    sets: HashMap<u32, Arc<CellSet>>,
}

impl CellCache {
    /// The set of `cluster`, and whether it came from the cache (false: built now).
    pub fn get(&mut self, scene: &LevelScene<'_>, pvs: &BitMatrix, cluster: u32) -> (Arc<CellSet>, bool) {
        if let Some(s) = self.sets.get(&cluster) {
            return (s.clone(), true);
        }
        let s = Arc::new(CellSet::build(scene, pvs, cluster));
        self.sets.insert(cluster, s.clone());
        (s, false)
    }

    /// Sets held.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    /// True when no set has been built.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }
}
