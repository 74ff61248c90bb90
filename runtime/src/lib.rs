//! `sightline-runtime`: load a compiled level and answer, every frame, what can be seen.

pub mod bvh;
