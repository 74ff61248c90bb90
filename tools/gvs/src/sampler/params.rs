//! The parameters of one run and their checks.

use serde::Serialize;

use super::{PROBE_RAYS, TARGET_RAYS};

/// How ABS samples the edges of the enlarged outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum EdgeMode {
    /// Recursive bisection while the two end rays hit different triangles (stock GVS).
    Bisect,
    /// The thesis' edge-point walk ("brzegowy"): from one end, jump just past the boundary of the
    /// object hit there, one ray per distinct object; bisection only where both ends miss.
    EdgePoint,
}

/// GVS parameters. Defaults (see [`Params::default`]) are the "stock" configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Params {
    /// Angular offset of the enlarged outline (radians). Default 1e-3.
    pub eps: f32,
    /// Edge sampling strategy. Default [`EdgeMode::Bisect`].
    pub edge: EdgeMode,
    /// Deepest bisection of an outline edge (the thesis' `tresh ≈ 2^-14` is depth 14). Default 14.
    pub max_depth: u32,
    /// Distance-scaled threshold ("adt"): stop bisecting a segment whose angular size seen from the
    /// origin is under this (radians). `None` disables it. Default `None`.
    pub adt: Option<f32>,
    /// Cast a ray at the middle of every outline edge before walking it (edge-point mode only).
    /// Default true.
    pub midpoint: bool,
    /// A hit nearer than the aimed point by more than this fraction of the aimed distance is a
    /// depth discontinuity. Default 0.05.
    pub disc: f32,
    /// Reverse sampling at discontinuities. Default true.
    pub reverse: bool,
    /// Silhouette re-seeding (see `Gvs::reseed_silhouette`; not in the thesis). Default false.
    pub silhouette: bool,
    /// Neighbour probing (see `Gvs::probe_neighbours`; not in the thesis). Default false.
    pub probe: bool,
    /// Rays neighbour probing casts at a probed triangle its fixed rays missed, each from a
    /// random point of the cell in front of it at a random point of it. Default [`PROBE_RAYS`].
    pub probe_rays: u32,
    /// Target sampling (see `Gvs::sample_targets`; not in the thesis): triangles aimed at per
    /// group of nearby triangles with unreached surface components, each by up to `target_rays`
    /// rays, once random sampling has ended. 0 disables it. Default 0.
    pub targets: u32,
    /// Most rays target sampling aims at one triangle. Default [`TARGET_RAYS`].
    pub target_rays: u32,
    /// The thesis' "first" random-ray strategy: cast this many random rays before any ABS (their
    /// new triangles queue up as seeds), then go on as usual. 0 is the stock "last" strategy
    /// (random rays only when the queue is empty). Default 0.
    pub first: u64,
    /// Cap on all rays. Default 10 M (the thesis' cap). It is checked between steps, so a run
    /// may pass it by the few rays of one step (a seed's nine outline rays); a run that reaches
    /// it says so in [`Stats::capped`](super::Stats::capped).
    pub max_rays: u64,
    /// Cap on random rays. Default 1 M.
    pub max_random: u64,
    /// Termination window: stop when the last `window` rays found fewer than `min_new` new
    /// triangles. Default 25 k (measured: on the generated city and sphere scenes 25 k gives the
    /// same PVS and pixel error as 100 k, for a quarter of the proof rays).
    pub window: u64,
    /// See `window`. Default 1.
    pub min_new: u32,
    /// First Halton index of the random rays (different seeds give different ray sets). Default 1.
    pub seed: u64,
}

impl Default for Params {
    fn default() -> Params {
        Params {
            eps: 1e-3,
            edge: EdgeMode::Bisect,
            max_depth: 14,
            adt: None,
            midpoint: true,
            disc: 0.05,
            reverse: true,
            silhouette: false,
            probe: false,
            probe_rays: PROBE_RAYS,
            targets: 0,
            target_rays: TARGET_RAYS,
            first: 0,
            max_rays: 10_000_000,
            max_random: 1_000_000,
            window: 25_000,
            min_new: 1,
            seed: 1,
        }
    }
}

/// A [`Params`] field outside the range its documentation gives.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// `eps` is not in (0, 1] radians.
    #[error("eps {0}: the enlarged outline's angular offset must be in (0, 1] radians")]
    Eps(f32),
    /// `disc` is not in [0, 1).
    #[error("disc {0}: the relative depth-discontinuity threshold must be in [0, 1)")]
    Disc(f32),
    /// `adt` is not a positive, finite angle.
    #[error("adt {0}: the distance-scaled threshold must be a positive number of radians")]
    Adt(f32),
}

impl Params {
    /// Check the ranges of the floating-point fields: `eps` in (0, 1], `disc` in [0, 1), `adt`
    /// positive and finite. A NaN in any of them would not fail a run but silently turn a part of
    /// GVS off (a NaN `eps` casts no edge rays, a NaN `disc` finds no discontinuity), so callers
    /// taking parameters from users check them first. The integer fields have no invalid values:
    /// `max_rays` bounds every run.
    pub fn check(&self) -> Result<(), ParamError> {
        if !(self.eps > 0.0 && self.eps <= 1.0) {
            return Err(ParamError::Eps(self.eps));
        }
        if !(self.disc >= 0.0 && self.disc < 1.0) {
            return Err(ParamError::Disc(self.disc));
        }
        match self.adt {
            Some(a) if !(a > 0.0 && a.is_finite()) => Err(ParamError::Adt(a)),
            _ => Ok(()),
        }
    }
}
