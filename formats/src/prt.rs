//! Quake portal files: PRT1, PRT2 and PRT1-AM (see `../shared/reference/formats.md`).
//!
//! Convention: the plane of a portal's winding (computed as for `.map` sides, see
//! [`crate::geom`]) faces **into** `leaves[0]`.

use crate::geom::Winding;

/// Which variant a portal file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrtFormat {
    /// One vis leaf per cluster; portal lines name leaves.
    Prt1,
    /// Quake 1 detail clusters; portal lines name clusters, then a leaf list per cluster.
    Prt2,
    /// Older clusters variant; portal lines name clusters, then one cluster number per leaf.
    Prt1Am,
}

/// One portal line.
#[derive(Debug, Clone, PartialEq)]
pub struct PrtPortal {
    /// The two clusters (leaves in PRT1) it joins; the winding faces into `leaves[0]`.
    pub leaves: [u32; 2],
    /// The convex winding.
    pub winding: Winding,
}

/// A whole portal file.
#[derive(Debug, Clone, PartialEq)]
pub struct PortalFile {
    /// The variant.
    pub format: PrtFormat,
    /// Number of vis leaves (real leaves, numbered from 0).
    pub num_leaves: u32,
    /// Number of clusters (equal to `num_leaves` for PRT1).
    pub num_clusters: u32,
    /// Portals between clusters.
    pub portals: Vec<PrtPortal>,
    /// Cluster of each vis leaf (`0..num_leaves`); the identity for PRT1.
    pub leaf_clusters: Vec<u32>,
}
