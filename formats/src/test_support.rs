//! Helpers shared by the crate's unit tests.

/// Apply random text edits, as proptest draws them: `(position, byte, op)` with op 0 inserting
/// `byte`, 1 overwriting with it, 2 deleting; positions wrap around the current length.
pub(crate) fn apply_edits(bytes: &mut Vec<u8>, edits: &[(usize, u8, u8)]) {
    for &(at, byte, op) in edits {
        let at = at % (bytes.len() + 1);
        match op {
            0 => bytes.insert(at, byte),
            1 if at < bytes.len() => bytes[at] = byte,
            _ if at < bytes.len() => {
                bytes.remove(at);
            }
            _ => {}
        }
    }
}
