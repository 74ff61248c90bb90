//! Quake 2's PHS (potentially hearable set): per cluster, the clusters a sound there may reach,
//! stored beside the PVS in a Quake 2 BSP's visibility lump ([`sightline_formats::bsp::q2`]).
//! Servers use it to send a sound only to the clients that may hear it. A [`crate::World`] holds
//! the PVS only; [`crate::load::load_q2`] returns the PHS beside it.

use sightline_formats::bsp::q2::Q2Bsp;

use crate::pvs::{Bitset, PvsRows};

/// The PHS rows of a Quake 2 BSP, kept compressed and decoded one row at a time (no allocation
/// once the caller's [`Bitset`] has grown to the cluster count).
#[derive(Debug, Clone)]
pub struct Phs {
    rows: PvsRows,
}

impl Phs {
    /// The PHS of a Quake 2 BSP read by [`sightline_formats::bsp::q2::read`] (which checked that
    /// every row decodes); `None` when the file has no visibility lump (not vised).
    pub fn from_q2(file: &Q2Bsp) -> Option<Self> {
        let vis = file.vis.as_ref()?;
        let num_clusters = u32::try_from(vis.num_clusters).ok()?;
        let offsets = vis.offsets.iter().map(|o| o[1]).collect();
        Some(Self { rows: PvsRows::from_parts(num_clusters, offsets, vis.data.clone()) })
    }

    /// Decode the PHS row of `cluster` into `out` (resized to the cluster count; bit `j` set
    /// means a sound in cluster `j` may be heard). For a cluster out of range (the listener in
    /// solid) every bit is set, as for the PVS.
    pub fn decode(&self, cluster: u32, out: &mut Bitset) {
        self.rows.decode(cluster, out);
    }
}
