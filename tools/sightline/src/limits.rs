//! The bounds of the numeric arguments: every count a user gives has a range that clap checks
//! (its error names the flag, exit 2), wide enough that no real run reaches it and narrow enough
//! that no value can make a run allocate without bound or overflow; the memory a number drives
//! (frames, image pixels, random-ray batches, worker threads) is estimated against what the
//! process may still take ([`fits_memory`]) before anything is allocated.

use anyhow::bail;
use clap::builder::RangedU64ValueParser;
use sightline_compiler::memory::{self, LimitSource, format_size};

/// Most worker threads (`--threads`): more than any machine this runs on has cores, few enough to
/// start at once (100 000 threads took 22 s to start, and then failed).
pub const MAX_THREADS: usize = 1024;

/// Most rays of a ray budget (`--rays`, `--max-rays`, ...): a day of one core's casting.
pub const MAX_RAYS: u64 = 1_000_000_000_000;

/// `--threads` where 0 means "choose": `0..=MAX_THREADS`.
pub fn threads_or_auto() -> RangedU64ValueParser<usize> {
    RangedU64ValueParser::new().range(0..=MAX_THREADS as u64)
}

/// `--threads` given as a count: `1..=MAX_THREADS`.
pub fn threads() -> RangedU64ValueParser<usize> {
    RangedU64ValueParser::new().range(1..=MAX_THREADS as u64)
}

/// A rayon pool of `threads` workers (0: one per core); a failure to start them names
/// `--threads` and says why once (rayon's error repeats its cause as its source).
pub fn pool(threads: usize) -> anyhow::Result<rayon::ThreadPool> {
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) => Ok(pool),
        Err(e) => bail!("--threads {threads}: cannot start the worker threads: {e}"),
    }
}

/// Refuses, before allocating it, `need` bytes for `what` (the flags that drive it) on `threads`
/// threads when the process may take less ([`memory::limit`]: the memory available, the memory
/// cgroup's limit, the address-space limit).
pub fn fits_memory(what: &str, need: u64, threads: usize) -> anyhow::Result<()> {
    if let Some((limit, source)) = memory::limit(None, threads)
        && need > limit
    {
        // These commands take no --max-memory: the machine's memory is just "available".
        let under = match source {
            LimitSource::Available | LimitSource::Explicit => "available".to_string(),
            LimitSource::Cgroup | LimitSource::Rlimit => source.to_string(),
        };
        bail!(
            "{what} would need {} of memory, more than the {} {under}; ask for less",
            format_size(need),
            format_size(limit)
        );
    }
    Ok(())
}

/// A number of type `T` from the command line that must lie in `range` (for floats, which clap
/// cannot range-check itself); `what` says what the number is. NaN and infinities are refused.
pub fn float_in<T>(
    range: impl std::ops::RangeBounds<T> + Clone + Send + Sync + 'static,
    what: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + PartialOrd + Into<f64> + Copy + Send + Sync + 'static,
{
    move |s: &str| {
        let bounds = describe(&range);
        match s.trim().parse::<T>() {
            Ok(v) if v.into().is_finite() && range.contains(&v) => Ok(v),
            _ => Err(format!("`{s}` is not {what} in {bounds}")),
        }
    }
}

/// `range` written as an interval: `(0, 180)`, `[0, 1)`, `(0, inf)`.
fn describe<T: Into<f64> + Copy>(range: &impl std::ops::RangeBounds<T>) -> String {
    use std::ops::Bound::*;
    let (open, lo) = match range.start_bound() {
        Included(v) => ("[", (*v).into().to_string()),
        Excluded(v) => ("(", (*v).into().to_string()),
        Unbounded => ("(", "-inf".to_string()),
    };
    let (hi, close) = match range.end_bound() {
        Included(v) => ((*v).into().to_string(), "]"),
        Excluded(v) => ((*v).into().to_string(), ")"),
        Unbounded => ("inf".to_string(), ")"),
    };
    format!("{open}{lo}, {hi}{close}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_outside_their_range_or_not_finite_are_refused_saying_the_range() {
        use std::ops::Bound::Excluded;
        let fov = float_in((Excluded(0.0f64), Excluded(180.0)), "a field of view in degrees");
        assert_eq!(fov("90"), Ok(90.0));
        for bad in ["0", "180", "-1", "NaN", "inf", "x"] {
            let e = fov(bad).expect_err(bad);
            assert!(e.contains("(0, 180)") && e.contains(bad), "{e}");
        }
        let disc = float_in(0.0f32..1.0, "a fraction");
        assert!(disc("0").is_ok() && disc("1").is_err());
        assert!(disc("1").expect_err("1").contains("[0, 1)"));
        let open = float_in(0.5f32.., "a size");
        assert!(open("1e30").is_ok() && open("0.4").is_err() && open("inf").is_err());
    }

    #[test]
    fn more_memory_than_there_is_is_refused_naming_what_needs_it() {
        assert!(fits_memory("nothing", 0, 1).is_ok());
        if memory::limit(None, 1).is_some() {
            let e = fits_memory("--frames 7", u64::MAX, 1).expect_err("more than any machine has");
            assert!(e.to_string().contains("--frames 7"), "{e}");
        }
    }
}
