//! The interface every culling backend implements ([`Backend`], re-exported as
//! [`crate::backend::Backend`]). Backends depend on it and on the world, never the reverse.

use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::world::World;

/// A culling strategy. Implementations hold no per-frame state: everything mutable lives in the
/// caller's [`Scratch`], so one backend value serves every thread.
pub trait Backend: Send + Sync + std::fmt::Debug {
    /// Short lowercase name (`"pvs"`, `"portal"`, ...), used by the CLI, the C ABI and reports.
    fn name(&self) -> &'static str;

    /// True when this backend can answer for `world` (the portal backend needs portals, the GVS
    /// one cells): every world unless the backend says otherwise.
    fn supports(&self, world: &World) -> bool {
        let _ = world;
        true
    }

    /// True when the backend never hides a visible leaf or face (every backend but the
    /// ray-casting one, whose sparse rays may miss what lies between them, and the GVS one,
    /// whose sets are sampled).
    fn conservative(&self) -> bool {
        true
    }

    /// Fill `out` (cleared first) with what `view` may see, front to back.
    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible);
}
