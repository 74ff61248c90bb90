//! What a command that ran to its end found, as the exit code says it.

/// What a successful command found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Nothing to report: exit 0.
    Clean,
    /// A finding such as a leak or a validation miss: exit 1.
    Finding,
}
