//! `--state` checkpoints: the finished flow portals of a run, so an interrupted run resumes without
//! redoing them.
//!
//! The file is bincode 2 (serde, fixed-width integers, little-endian) of [`State`], followed by a
//! trailer of 8 bytes: [`fnv1a`] (FNV-1a 64) of everything before it, little-endian. It is written with
//! [`sightline_job::atomic::write_file_atomic`] (a crash leaves the previous checkpoint).
//!
//! What is stored is the *log* of the batch boundaries, not a snapshot of the matrices: for each
//! finished portal (in processing order) its row as it was folded into the matrix, the chains its
//! flow visited, whether a beam cull of it dropped a portal and, on a batch's last portal, the
//! seed pairs ([`super::seeds`]) the batch added. A resume replays that log from the `mightsee`
//! rows exactly as the batch boundaries did ([`State::replay`]), so the rows, the seeds and the
//! run of quiet flows ([`super::flow::quiet_after`]) a resumed run starts from are exactly those
//! of the uninterrupted run after the same batches, and any prefix of whole batches is itself a
//! valid state. (A snapshot cannot be cut back: its early rows were tightened, and its seeds
//! added, by portals after the cut.) `done` must be a whole number of batches: the resumed run
//! batches the rest from there, so any other count would batch it differently from the
//! uninterrupted run (on dm1, 30 pairs fewer).
//!
//! Nothing in a state is trusted: the checksum catches damage, the header must match the portal
//! file (a hash of it as [`sightline_formats::prt::write`] prints it, and of the options that
//! change results), and the replay checks every row and pair against what the boundaries could
//! have produced (a folded row only narrows the current one, no bit past the row's length, seed
//! clusters in range, each pair new). Any failure is a [`VisError::State`] naming the file, never
//! a different PVS. Decoding is bounded by a limit sized from the file length, so a corrupt length
//! field cannot allocate more than the file justifies.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use sightline_formats::bits;
use sightline_formats::hash::{FNV_OFFSET, fnv1a};
use sightline_job::atomic::write_file_atomic;

use super::error::VisError;
use super::{flow, seeds, symmetry};

/// Identifies the state format and the flow's rules ("SLVISST6": the log of batch boundaries
/// with a checksum, written by flows that also record the clusters they saw as seeds, whose
/// beam-cull trial follows the flows folded before them, and whose certified seeds have a row
/// per portal ([`super::seeds`])). A run under other rules would continue
/// a state differently from its own uninterrupted run, so a change of what the flow records takes
/// a new tag.
const MAGIC: u64 = 0x534c_5649_5353_5436;

/// Bytes of the checksum trailer.
const TRAILER: usize = 8;

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
    /// Number of clusters (the range of a seed pair's `to`; its `from` is a row of
    /// [`super::seeds::Seeds`], `portals + clusters` of them).
    pub clusters: u64,
    /// Portals of the processing order that are finished: a multiple of the batch size, or all.
    pub done: u64,
    /// Per finished portal, `words` each in processing order: its row as folded at its batch
    /// boundary (the matrix row right after [`symmetry::replace_row`]).
    pub rows: Vec<u64>,
    /// Per finished portal, the portal chains its flow visited.
    pub chains: Vec<u64>,
    /// Per finished portal, whether a beam cull of its flow dropped a portal.
    pub dropped: Vec<bool>,
    /// Per finished portal, how many of `pairs` it added: a batch sets its pairs together at its
    /// boundary, and the log gives them to the batch's last portal (the others add none).
    pub added: Vec<u32>,
    /// Seed pairs `(from, to)` in the order the boundaries set them (per batch, in `(from, to)`
    /// order), each new when set.
    pub pairs: Vec<[u32; 2]>,
}

impl State {
    /// An empty state (nothing finished) for this run.
    pub fn new(input_hash: u64, portals: usize, words: usize, clusters: usize) -> Self {
        Self {
            magic: MAGIC,
            input_hash,
            portals: portals as u64,
            words: words as u64,
            clusters: clusters as u64,
            done: 0,
            rows: Vec::new(),
            chains: Vec::new(),
            dropped: Vec::new(),
            added: Vec::new(),
            pairs: Vec::new(),
        }
    }

    /// Record one finished portal: its folded row, its chains, whether a beam cull of it dropped
    /// a portal, and the seed pairs it added.
    pub fn push(
        &mut self,
        row: &[u64],
        chains: u64,
        dropped: bool,
        pairs: impl IntoIterator<Item = (u32, u32)>,
    ) {
        self.rows.extend_from_slice(row);
        self.chains.push(chains);
        self.dropped.push(dropped);
        let before = self.pairs.len();
        self.pairs.extend(pairs.into_iter().map(|(a, b)| [a, b]));
        self.added.push((self.pairs.len() - before) as u32);
        self.done += 1;
    }

    /// Keep only the first `done` finished portals (a checkpoint of fewer batches).
    #[cfg(test)]
    pub fn truncate(&mut self, done: usize) {
        let keep: u32 = self.added[..done].iter().sum();
        self.rows.truncate(done * self.words as usize);
        self.chains.truncate(done);
        self.dropped.truncate(done);
        self.added.truncate(done);
        self.pairs.truncate(keep as usize);
        self.done = done as u64;
    }

    /// Chains of the finished portals.
    pub fn total_chains(&self) -> u64 {
        self.chains.iter().fold(0u64, |a, &c| a.saturating_add(c))
    }

    /// Rebuild the matrix and the seeds the batch boundaries had after the first `done` portals of
    /// `order`: `test` must hold the `mightsee` rows made consistent by
    /// [`symmetry::tighten_all`], `seeds` zeros (`bits::words(clusters)` words per seed row).
    /// Returns the run of quiet flows at that point ([`flow::quiet_after`]). Fails, with the
    /// reason, when the log is not one the boundaries could have written.
    pub fn replay(&self, order: &[usize], test: &mut [u64], seeds: &mut [u64]) -> Result<usize, String> {
        let words = self.words as usize;
        let n = self.portals as usize;
        let nc = self.clusters as usize;
        let cw = bits::words(nc);
        let mut pairs = self.pairs.iter();
        let mut quiet = 0;
        for (k, &p) in order[..self.done as usize].iter().enumerate() {
            let row = &self.rows[k * words..(k + 1) * words];
            if let Some(w) = (0..words).find(|&w| row[w] & !bits::valid_mask(w, n) != 0) {
                return Err(format!("finished portal {k} has bits set past the {n} portals (word {w})"));
            }
            let current = &test[p * words..(p + 1) * words];
            if row.iter().zip(current).any(|(r, c)| r & !c != 0) {
                return Err(format!("finished portal {k} has a row its flow could not have produced"));
            }
            symmetry::replace_row(test, words, p, row);
            let Some(&dropped) = self.dropped.get(k) else {
                return Err(format!("no cull record for finished portal {k}"));
            };
            quiet = flow::quiet_after(quiet, dropped);
            for _ in 0..self.added[k] {
                let Some(&[from, to]) = pairs.next() else {
                    return Err("fewer seed pairs than counted".to_string());
                };
                let (from, to) = (from as usize, to as usize);
                if from >= seeds::Seeds::rows(n, nc) || to >= nc {
                    return Err(format!(
                        "seed pair ({from}, {to}) out of range ({n} portals, {nc} clusters)"
                    ));
                }
                let seed_row = &mut seeds[from * cw..(from + 1) * cw];
                if bits::get(seed_row, to) {
                    return Err(format!("seed pair ({from}, {to}) recorded twice"));
                }
                bits::set(seed_row, to);
            }
        }
        if pairs.next().is_some() {
            return Err("more seed pairs than counted".to_string());
        }
        Ok(quiet)
    }
}

/// An upper bound of the bytes a state log takes for `portals` one-way portals of `words` words
/// and `clusters` clusters: every portal finished (its row, chains, cull flag and pair count) and every
/// seed pair recorded (each pair is new when set, so at most a pair of 8 bytes per bit of the seed
/// matrix, `(portals + clusters) × clusters`), counted twice: saving encodes the whole log into
/// one buffer beside it, and loading holds the file's bytes beside the decoded log.
pub fn bytes_bound(portals: u128, words: u128, clusters: u128) -> u128 {
    let per_portal = 8 * words + 8 + 1 + 4;
    let header = 8 * 8 + 5 * 8 + TRAILER as u128;
    2 * (portals * per_portal + 8 * (portals + clusters) * clusters + header)
}

fn config() -> bincode::config::Configuration<bincode::config::LittleEndian, bincode::config::Fixint> {
    bincode::config::standard().with_fixed_int_encoding()
}

/// The bytes of a sealed file: `value` encoded (bincode 2, fixed-width little-endian integers)
/// and its checksum trailer (FNV-1a 64 of the bytes before it). The shape of `--state` files and
/// of shard files ([`super::shard`]), whose values start with their format's magic.
pub(super) fn seal<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    let mut bytes = bincode::serde::encode_to_vec(value, config()).map_err(|e| e.to_string())?;
    let sum = fnv1a(&bytes, FNV_OFFSET);
    bytes.extend_from_slice(&sum.to_le_bytes());
    Ok(bytes)
}

/// The file's bytes: the encoded state and its checksum.
fn encode(state: &State) -> Result<Vec<u8>, String> {
    seal(state)
}

/// Write `state` atomically ([`write_file_atomic`]).
pub fn save(path: &Path, state: &State) -> Result<(), VisError> {
    let bytes =
        encode(state).map_err(|e| VisError::State(format!("{}: cannot encode: {e}", path.display())))?;
    write_file_atomic(path, &bytes).map_err(|e| VisError::State(format!("{}: {e}", path.display())))
}

fn decode_with<T: DeserializeOwned, const N: usize>(
    bytes: &[u8],
) -> Result<(T, usize), bincode::error::DecodeError> {
    bincode::serde::decode_from_slice(bytes, config().with_limit::<N>())
}

/// Decode with the smallest power-of-two limit that holds the file (bincode's limit is a const).
fn decode_payload<T: DeserializeOwned>(bytes: &[u8], what: &str) -> Result<(T, usize), String> {
    // Fixed-width encoding: the bytes a value claims in memory equal its encoded length.
    let need = bytes.len() as u64 + 1024;
    macro_rules! tiers {
        ($($k:literal)*) => {
            $(if need <= 1u64 << $k { return decode_with::<T, { 1usize << $k }>(bytes).map_err(|e| e.to_string()); })*
        };
    }
    tiers!(12 14 16 18 20 22 24 26 28 30 32 34 36);
    Err(format!("file of {} bytes is too large for a {what}", bytes.len()))
}

/// The value sealed in `bytes` ([`seal`]): its first 8 bytes the `magic` of `what` (a vis state,
/// a vis shard), its checksum verified, every byte used, and decoding bounded by a limit sized
/// from the file's length.
pub(super) fn unseal<T: DeserializeOwned>(bytes: &[u8], magic: u64, what: &str) -> Result<T, String> {
    let Some(split) = bytes.len().checked_sub(TRAILER) else {
        return Err(format!("file of {} bytes is too short for a {what}", bytes.len()));
    };
    let (payload, trailer) = bytes.split_at(split);
    let mut sum = [0u8; TRAILER];
    sum.copy_from_slice(trailer);
    if payload.len() < 8 || payload[..8] != magic.to_le_bytes() {
        return Err(format!("bytes 0..8 are not the magic of a {what} of this version"));
    }
    if u64::from_le_bytes(sum) != fnv1a(payload, FNV_OFFSET) {
        return Err(format!(
            "the checksum at offset {split} does not match bytes 0..{split}: the file is damaged"
        ));
    }
    let (value, used) = decode_payload(payload, what)?;
    if used != payload.len() {
        return Err(format!("{} bytes of garbage after the {what}", payload.len() - used));
    }
    Ok(value)
}

/// The state in `bytes`, its checksum verified and every byte used.
fn decode(bytes: &[u8]) -> Result<State, String> {
    unseal(bytes, MAGIC, "vis state")
}

/// What a run needs a state to match.
#[derive(Debug, Clone, Copy)]
pub struct Expect {
    /// Hash of the input and of the options that change results.
    pub input_hash: u64,
    /// One-way portals.
    pub portals: usize,
    /// Words per row.
    pub words: usize,
    /// Clusters.
    pub clusters: usize,
    /// Portals per batch: `done` must be a multiple of it (or every portal).
    pub batch: usize,
}

/// Load a state if the file exists; refuse one from another input, other options, or a damaged
/// or inconsistent file (every error names the file). The rows and pairs are checked by
/// [`State::replay`].
pub fn load(path: &Path, want: &Expect) -> Result<Option<State>, VisError> {
    let bytes = match sightline_job::input::read_input(path) {
        Ok(b) => b,
        Err(e) if e.is_not_found() => return Ok(None),
        Err(e) => {
            let cause = std::error::Error::source(&e).map(|c| format!(": {c}")).unwrap_or_default();
            return Err(VisError::State(format!("{e}{cause}")));
        }
    };
    let state = decode(&bytes).map_err(|e| {
        VisError::State(format!("{}: not a usable vis state ({e}); delete it to start over", path.display()))
    })?;
    let header = [
        ("input hash", state.input_hash, want.input_hash),
        ("portal count", state.portals, want.portals as u64),
        ("row words", state.words, want.words as u64),
        ("cluster count", state.clusters, want.clusters as u64),
    ];
    if let Some((field, got, wanted)) = header.iter().find(|(_, got, wanted)| got != wanted) {
        return Err(VisError::State(format!(
            "{}: state belongs to another portal file or other options (header field {field} is {got}, \
             this run's is {wanted}); delete it to start over",
            path.display()
        )));
    }
    let done = state.done;
    let problem = if done > state.portals {
        Some(format!("{done} finished portals of {}", state.portals))
    } else if done != state.portals && !done.is_multiple_of(want.batch as u64) {
        Some(format!("{done} finished portals is not a whole number of batches of {}", want.batch))
    } else if state.rows.len() as u64 != done * state.words
        || state.chains.len() as u64 != done
        || state.dropped.len() as u64 != done
        || state.added.len() as u64 != done
    {
        Some(format!("the per-portal records do not match {done} finished portals"))
    } else if state.added.iter().map(|&a| u64::from(a)).sum::<u64>() != state.pairs.len() as u64 {
        Some("the seed pair counts do not add up".to_string())
    } else {
        None
    };
    match problem {
        Some(p) => Err(inconsistent(path, &p)),
        None => Ok(Some(state)),
    }
}

/// The input hash a state file at `path` says it has: which of a `--coarsen` run's merges it
/// belongs to (see `run`). Only the file's first 16 bytes are read (a state is encoded with
/// fixed-width integers, [`State::magic`] then [`State::input_hash`]); [`load`] then reads and
/// checks the whole file. `None` for a missing file, one that is not a regular file, or one
/// without this version's magic, which [`load`] then reports.
pub fn input_hash_of(path: &Path) -> Option<u64> {
    let head = sightline_job::input::read_input_head(path, 16).ok()?;
    let (magic, hash) = (head.get(..8)?, head.get(8..16)?);
    (magic == MAGIC.to_le_bytes()).then(|| u64::from_le_bytes(hash.try_into().unwrap_or_default()))
}

/// The error for a state whose content cannot come from a run.
pub fn inconsistent(path: &Path, problem: &str) -> VisError {
    VisError::State(format!(
        "{}: inconsistent vis state ({problem}); delete it to start over",
        path.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expect(input_hash: u64) -> Expect {
        Expect { input_hash, portals: 10, words: 1, clusters: 5, batch: 2 }
    }

    fn sample() -> State {
        let mut st = State::new(42, 10, 1, 5);
        st.push(&[5], 3, true, [(0, 1)]);
        st.push(&[7], 4, false, [(1, 2), (2, 0)]);
        st
    }

    /// A run picks the merge a state file belongs to by its head alone.
    #[test]
    fn the_input_hash_is_read_from_the_head() {
        let dir = std::env::temp_dir().join(format!("sightline-vis-state-head-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.state");
        save(&path, &sample()).expect("save");
        assert_eq!(input_hash_of(&path), Some(42));
        let good = std::fs::read(&path).expect("read");
        let mut other = good.clone();
        other[8] ^= 1;
        std::fs::write(&path, &other).expect("write");
        assert_eq!(input_hash_of(&path), Some(42 ^ 1), "the head only: load checks the rest");
        for bad in [&good[..15], &[&good[..7], &[good[7] ^ 1], &good[8..]].concat()[..]] {
            std::fs::write(&path, bad).expect("write");
            assert_eq!(input_hash_of(&path), None, "{} bytes", bad.len());
        }
        assert_eq!(input_hash_of(&dir), None, "a folder");
        assert_eq!(input_hash_of(&dir.join("missing")), None);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn save_load_and_refuse_stale_or_damaged() {
        let dir = std::env::temp_dir().join(format!("sightline-vis-state-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.state");
        let st = sample();
        assert_eq!(st.total_chains(), 7);
        save(&path, &st).expect("save");
        assert_eq!(load(&path, &expect(42)).expect("load"), Some(st.clone()));
        // Another input, cluster count or batch size is refused.
        assert!(load(&path, &expect(43)).is_err());
        assert!(load(&path, &Expect { clusters: 6, ..expect(42) }).is_err());
        assert!(load(&path, &Expect { batch: 4, ..expect(42) }).is_err());
        // Every single flipped byte is refused, with the file named.
        let good = std::fs::read(&path).expect("read");
        for i in 0..good.len() {
            let mut bad = good.clone();
            bad[i] ^= 0x10;
            std::fs::write(&path, &bad).expect("write");
            match load(&path, &expect(42)) {
                Err(VisError::State(m)) => assert!(m.contains("s.state"), "{m}"),
                other => panic!("byte {i} flipped: {other:?}"),
            }
        }
        // Truncated or extended files too.
        for bad in [&good[..good.len() - 1], &good[..3], &[good.as_slice(), &[0]].concat()] {
            std::fs::write(&path, bad).expect("write");
            assert!(load(&path, &expect(42)).is_err());
        }
        // A huge claimed length in a tiny file is refused, not allocated (checksum made right).
        let mut bytes = bincode::serde::encode_to_vec(sample(), config()).expect("enc");
        let len_at = 8 * 6;
        bytes[len_at..len_at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let sum = fnv1a(&bytes, FNV_OFFSET);
        bytes.extend_from_slice(&sum.to_le_bytes());
        std::fs::write(&path, &bytes).expect("write");
        assert!(load(&path, &expect(42)).is_err());
        // A `done` between batches is refused (the rest would be batched differently).
        let mut cut = sample();
        cut.truncate(1);
        save(&path, &cut).expect("save");
        match load(&path, &expect(42)) {
            Err(VisError::State(m)) => assert!(m.contains("batches"), "{m}"),
            other => panic!("a cut between batches accepted: {other:?}"),
        }
        // Records that disagree with `done` are refused.
        for tamper in [
            |s: &mut State| s.done = 1,
            |s: &mut State| s.done = 11,
            |s: &mut State| {
                s.chains.pop();
            },
            |s: &mut State| {
                s.dropped.pop();
            },
            |s: &mut State| s.added[0] = 2,
            |s: &mut State| {
                s.pairs.pop();
            },
        ] {
            let mut bad = sample();
            tamper(&mut bad);
            save(&path, &bad).expect("save");
            match load(&path, &expect(42)) {
                Err(VisError::State(m)) => assert!(m.contains("inconsistent"), "{m}"),
                other => panic!("tampered state accepted: {other:?}"),
            }
        }
        assert_eq!(load(&dir.join("absent"), &expect(42)).expect("absent"), None);
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn bytes_bound_covers_a_full_log_and_its_encoding() {
        // Every portal finished and every seed pair recorded: the largest log of its counts.
        let (portals, words, clusters) = (70usize, 2usize, 9u32);
        let mut st = State::new(1, portals, words, clusters as usize);
        let rows = seeds::Seeds::rows(portals, clusters as usize) as u32;
        let all: Vec<(u32, u32)> = (0..rows).flat_map(|a| (0..clusters).map(move |b| (a, b))).collect();
        for k in 0..portals {
            let pairs = if k + 1 == portals { all.clone() } else { Vec::new() };
            st.push(&vec![u64::MAX; words], u64::MAX, true, pairs);
        }
        let encoded = encode(&st).expect("encode").len() as u128;
        let in_memory = (st.rows.len() * 8
            + st.chains.len() * 8
            + st.dropped.len()
            + st.added.len() * 4
            + st.pairs.len() * 8) as u128;
        let bound = bytes_bound(portals as u128, words as u128, u128::from(clusters));
        assert!(bound >= encoded + in_memory, "bound {bound} < {encoded} + {in_memory}");
        assert!(bound <= 2 * (encoded + in_memory), "bound {bound} far above {encoded} + {in_memory}");
    }

    #[test]
    fn replay_refuses_rows_and_pairs_no_run_could_write() {
        // 4 portals, 2 clusters (6 seed rows); every portal might see every other.
        let order = [0, 1, 2, 3];
        let fresh = || (vec![0b1111u64; 4], vec![0u64; 6]);
        let mut st = State::new(1, 4, 1, 2);
        st.push(&[0b1100], 1, true, [(0, 1)]);
        st.push(&[0b1000], 1, false, [(5, 0)]);
        let (mut test, mut seeds) = fresh();
        let quiet = st.replay(&order, &mut test, &mut seeds).expect("a log a run could write");
        assert_eq!(quiet, 1, "one quiet flow since the last that dropped a portal");
        assert_eq!(seeds, vec![0b10, 0, 0, 0, 0, 0b01]);
        assert_eq!(&test[..2], &[0b1100, 0b1000]);
        let bad: [fn(&mut State); 6] = [
            |s| s.rows[0] |= 1 << 4, // a padding bit
            |s| s.rows[1] = 0b0010,  // a bit portal 0's boundary cleared from row 1
            |s| s.pairs[1] = [0, 1], // a pair set twice
            |s| s.pairs[0] = [6, 0], // a row out of range
            |s| s.pairs[0] = [0, 2], // a cluster out of range
            |s| {
                s.dropped.pop(); // a finished portal without its cull record
            },
        ];
        for (i, tamper) in bad.iter().enumerate() {
            let mut b = st.clone();
            tamper(&mut b);
            let (mut test, mut seeds) = fresh();
            assert!(b.replay(&order, &mut test, &mut seeds).is_err(), "tamper {i} accepted");
        }
    }
}
