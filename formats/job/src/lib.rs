//! What long-running library work shares with whoever runs it: progress reports ([`progress`]),
//! the stop request ([`cancel`]), input files read within a bound ([`input`]), files written whole
//! or not at all ([`atomic`]), and the one seeded random generator, so a seed means the same
//! numbers for any thread count ([`rng`]).
//!
//! The compiler, validation and GVS baking take a [`progress::Progress`] and a
//! [`cancel::Cancel`]; the `sightline` binary draws the bars and turns Ctrl-C into a cancel.

pub mod apart;
pub mod atomic;
pub mod cancel;
pub mod input;
pub mod progress;
pub mod rng;
