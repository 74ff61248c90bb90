//! `--state` checkpoints: the finished flow rows of a run, so an interrupted run resumes without
//! redoing them.
//!
//! The file is bincode 2 (serde, fixed-width integers) of [`State`], written with
//! [`sightline_formats::atomic::write_file_atomic`] (a crash leaves the previous checkpoint). It records a hash of the portal file (as
//! [`sightline_formats::prt::write`] prints it) and of the options that change results; a state
//! from another input or other options is refused. Decoding is always bounded by a limit sized
//! from the file length, so a corrupt length field cannot allocate more than the file justifies.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sightline_formats::atomic::write_file_atomic;

use super::VisError;

/// Identifies the state format.
const MAGIC: u64 = 0x534c_5649_5353_5432; // "SLVISST2"

/// A checkpoint: the first `done` portals of the processing order are finished.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Format tag, [`MAGIC`].
    pub magic: u64,
    /// Hash of the input and of the options that change results.
    pub input_hash: u64,
    /// Number of one-way portals.
    pub portals: u64,
    /// Words per row.
    pub words: u64,
    /// Portals of the processing order that are finished.
    pub done: u64,
    /// Their final rows, `words` each, in processing order.
    pub rows: Vec<u64>,
    /// Seeds: per cluster, the clusters known visible from it by a certified line.
    pub seeds: Vec<u64>,
    /// Portal chains visited so far.
    pub chains: u64,
}

impl State {
    /// A state for this run.
    pub fn new(
        input_hash: u64,
        portals: usize,
        words: usize,
        done: usize,
        rows: Vec<u64>,
        seeds: Vec<u64>,
        chains: u64,
    ) -> Self {
        Self {
            magic: MAGIC,
            input_hash,
            portals: portals as u64,
            words: words as u64,
            done: done as u64,
            rows,
            seeds,
            chains,
        }
    }
}

/// FNV-1a, 64 bits: a stable hash for input identity (not for security).
pub fn fnv1a(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The starting value of [`fnv1a`].
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

fn config() -> bincode::config::Configuration<bincode::config::LittleEndian, bincode::config::Fixint> {
    bincode::config::standard().with_fixed_int_encoding()
}

/// Write `state` atomically ([`write_file_atomic`]).
pub fn save(path: &Path, state: &State) -> Result<(), VisError> {
    let bytes = bincode::serde::encode_to_vec(state, config())
        .map_err(|e| VisError::State(format!("{}: cannot encode: {e}", path.display())))?;
    write_file_atomic(path, &bytes).map_err(|e| VisError::State(format!("{}: {e}", path.display())))
}

fn decode_with<const N: usize>(bytes: &[u8]) -> Result<State, bincode::error::DecodeError> {
    bincode::serde::decode_from_slice(bytes, config().with_limit::<N>()).map(|(s, _)| s)
}

/// Decode with the smallest power-of-two limit that holds the file (bincode's limit is a const).
fn decode(bytes: &[u8]) -> Result<State, String> {
    // Fixed-width encoding: the bytes a state claims in memory equal its encoded length.
    let need = bytes.len() as u64 + 1024;
    macro_rules! tiers {
        ($($k:literal)*) => {
            $(if need <= 1u64 << $k { return decode_with::<{ 1usize << $k }>(bytes).map_err(|e| e.to_string()); })*
        };
    }
    tiers!(12 14 16 18 20 22 24 26 28 30 32 34 36);
    Err(format!("file of {} bytes is too large for a vis state", bytes.len()))
}

/// Load a state if the file exists; refuse one from another input, other options or a corrupt file.
/// `seeds` is the length the seed matrix must have.
pub fn load(
    path: &Path,
    input_hash: u64,
    portals: usize,
    words: usize,
    seeds: usize,
) -> Result<Option<State>, VisError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(VisError::State(format!("{}: {e}", path.display()))),
    };
    let state =
        decode(&bytes).map_err(|e| VisError::State(format!("{}: not a vis state: {e}", path.display())))?;
    if state.magic != MAGIC {
        return Err(VisError::State(format!("{}: not a vis state", path.display())));
    }
    if state.input_hash != input_hash || state.portals != portals as u64 || state.words != words as u64 {
        return Err(VisError::State(format!(
            "{}: state belongs to another portal file or other options; delete it to start over",
            path.display()
        )));
    }
    if state.done > state.portals
        || state.rows.len() as u64 != state.done * state.words
        || state.seeds.len() != seeds
    {
        return Err(VisError::State(format!("{}: inconsistent vis state", path.display())));
    }
    Ok(Some(state))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn save_load_and_refuse_stale() {
        let dir = std::env::temp_dir().join(format!("sightline-vis-state-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.state");
        let st = State::new(42, 10, 1, 2, vec![5, 7], vec![1; 10], 99);
        save(&path, &st).expect("save");
        assert_eq!(load(&path, 42, 10, 1, 10).expect("load"), Some(st));
        // Seeds sized for another cluster count are refused.
        assert!(load(&path, 42, 10, 1, 11).is_err());
        assert!(load(&path, 43, 10, 1, 10).is_err());
        std::fs::write(&path, [1u8, 2, 3]).expect("write");
        assert!(load(&path, 42, 10, 1, 10).is_err());
        // A huge claimed length in a tiny file is refused, not allocated.
        let mut bytes =
            bincode::serde::encode_to_vec(State::new(42, 10, 1, 2, vec![5, 7], vec![1; 10], 99), config())
                .expect("enc");
        let len_at = 8 * 5;
        bytes[len_at..len_at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &bytes).expect("write");
        assert!(load(&path, 42, 10, 1, 10).is_err());
        assert_eq!(load(&dir.join("absent"), 42, 10, 1, 10).expect("absent"), None);
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }
}
