//! Memory budgets: a job estimates what it will allocate before allocating it, and refuses
//! (with what it would need and why) when that is more than the process may still take, or more
//! than the caller allows.
//!
//! What the process may still take is the tightest of, on Linux (elsewhere there is no limit but
//! the caller's):
//! - `MemAvailable` of `/proc/meminfo`: what the machine has;
//! - the memory cgroup's limit less its usage (cgroup v2 `memory.max` / `memory.current`, v1
//!   `memory.limit_in_bytes` / `memory.usage_in_bytes`; every ancestor's too), as a container or a
//!   batch scheduler sets it;
//! - the address-space and data-size limits (`ulimit -v`, `ulimit -d`; `prlimit --as`) less the
//!   process's current size, less one [`ARENA_RESERVE`] and, per worker thread, another and a
//!   [`STACK_RESERVE`]: the C allocator reserves address space for a thread's arena when the
//!   thread first allocates (which may be after the check, even for a thread already started), so
//!   a limit on address space is met well before the data fills it.

/// Address space the system allocator reserves for one more arena (glibc's heap of 64 MiB on
/// 64-bit Linux): kept free under an address-space limit.
pub const ARENA_RESERVE: u64 = 64 << 20;
/// Address space a worker thread may still take for its stack (Rust's 2 MiB, with room to spare).
pub const STACK_RESERVE: u64 = 8 << 20;

/// Bytes available to a new allocation by the machine: `MemAvailable` on Linux, `None` (no
/// limit) elsewhere or when it cannot be read.
pub fn available() -> Option<u64> {
    parse_meminfo(&read_proc("/proc/meminfo")?)
}

/// A small file of `/proc` or `/sys`, read in one go (`read_to_string` starts small on files
/// whose size reads as 0, and took eight reads for `/proc/meminfo`).
fn read_proc(path: &str) -> Option<String> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    use std::io::Read;
    let mut text = String::with_capacity(8192);
    std::fs::File::open(path).ok()?.take(1 << 20).read_to_string(&mut text).ok()?;
    Some(text)
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn parse_meminfo(text: &str) -> Option<u64> {
    kb_field(text, "MemAvailable:")
}

/// A `Name:  1234 kB` field of `/proc/meminfo` or `/proc/self/status`, in bytes.
fn kb_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let mut words = line[name.len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => Some(value.saturating_mul(1024)),
        None => Some(value),
        Some(_) => None,
    }
}

/// The soft limit of a `/proc/self/limits` line starting `name` (`Max address space`), in bytes;
/// `None` when unlimited or absent.
fn soft_limit(limits: &str, name: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with(name))?;
    line[name.len()..].split_whitespace().next()?.parse().ok()
}

/// Headroom under the address-space and data-size limits of the process: the limit less the
/// current size (`VmSize`, `VmData` of `/proc/self/status`) less one [`ARENA_RESERVE`] and, per
/// worker thread of `threads`, another and a [`STACK_RESERVE`]; `None` without such limits.
fn rlimit_headroom(limits: &str, status: &str, threads: usize) -> Option<u64> {
    let per_thread = ARENA_RESERVE + STACK_RESERVE;
    let reserve = ARENA_RESERVE.saturating_add(per_thread.saturating_mul(threads as u64));
    let under = |name: &str, field: &str| {
        let limit = soft_limit(limits, name)?;
        Some(limit.saturating_sub(kb_field(status, field).unwrap_or(0)).saturating_sub(reserve))
    };
    match (under("Max address space", "VmSize:"), under("Max data size", "VmData:")) {
        (Some(a), Some(d)) => Some(a.min(d)),
        (a, d) => a.or(d),
    }
}

/// Headroom under the memory cgroup limits of the process (its own and every ancestor's), from the
/// text of `/proc/self/cgroup`; `read` reads a file of the cgroup file system.
fn cgroup_headroom(cgroups: &str, read: impl Fn(&str) -> Option<String>) -> Option<u64> {
    let number = |text: String| text.trim().parse::<u64>().ok();
    let mut best: Option<u64> = None;
    let mut consider = |limit: Option<u64>, usage: Option<u64>| {
        // cgroup v1 writes "no limit" as a huge number near 2^63.
        if let Some(limit) = limit.filter(|&l| l < 1 << 62) {
            let room = limit.saturating_sub(usage.unwrap_or(0));
            best = Some(best.map_or(room, |b| b.min(room)));
        }
    };
    for line in cgroups.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        let (root, limit_file, usage_file) = match controllers {
            "" => ("/sys/fs/cgroup", "memory.max", "memory.current"),
            c if c.split(',').any(|c| c == "memory") => {
                ("/sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes")
            }
            _ => continue,
        };
        // The cgroup and each ancestor up to the root of the hierarchy.
        let mut dir = path.trim_end_matches('/').to_string();
        loop {
            let at = |file: &str| read(&format!("{root}{dir}/{file}")).and_then(number);
            consider(at(limit_file), at(usage_file));
            match dir.rfind('/') {
                Some(i) => dir.truncate(i),
                None => break,
            }
            if dir.is_empty() {
                let at = |file: &str| read(&format!("{root}/{file}")).and_then(number);
                consider(at(limit_file), at(usage_file));
                break;
            }
        }
    }
    best
}

/// Where a limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// The memory the machine has available.
    Available,
    /// The memory cgroup's limit (a container's or a batch job's).
    Cgroup,
    /// The process's address-space or data-size limit (`ulimit -v`, `ulimit -d`).
    Rlimit,
    /// The caller's explicit maximum (`--max-memory`).
    Explicit,
}

impl std::fmt::Display for LimitSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LimitSource::Available => "available; see --max-memory",
            LimitSource::Cgroup => "left under the memory cgroup's limit",
            LimitSource::Rlimit => "left under the process's address-space limit (ulimit -v / -d)",
            LimitSource::Explicit => "allowed by --max-memory",
        })
    }
}

/// The limit a job run on `threads` threads must fit: the smallest of [`limits`]; `None` when there
/// is none.
pub fn limit(max: Option<u64>, threads: usize) -> Option<(u64, LimitSource)> {
    limits(max, threads).into_iter().min_by_key(|&(bytes, _)| bytes)
}

/// Every limit on a job run on `threads` threads, with where it comes from: `max` (the caller's),
/// the memory available, the cgroup's headroom and the rlimits' headroom (see the module docs).
/// All but `max` are room left beside what the process holds already.
pub fn limits(max: Option<u64>, threads: usize) -> Vec<(u64, LimitSource)> {
    let cgroup =
        read_proc("/proc/self/cgroup").and_then(|c| cgroup_headroom(&c, |p| std::fs::read_to_string(p).ok()));
    let rlimit = match (read_proc("/proc/self/limits"), read_proc("/proc/self/status")) {
        (Some(l), Some(s)) => rlimit_headroom(&l, &s, threads),
        _ => None,
    };
    [
        max.map(|m| (m, LimitSource::Explicit)),
        available().map(|a| (a, LimitSource::Available)),
        cgroup.map(|c| (c, LimitSource::Cgroup)),
        rlimit.map(|r| (r, LimitSource::Rlimit)),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The process's resident size (`VmRSS` of `/proc/self/status`); `None` where it cannot be read.
pub fn resident() -> Option<u64> {
    kb_field(&read_proc("/proc/self/status")?, "VmRSS:")
}

/// A size in bytes for people: `512 B`, `1.5 KiB`, `20.5 GiB`, `2.0 TiB`.
pub fn format_size(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    format!("{v:.1} {}", UNITS[unit])
}

/// Parse a size: bytes (`1048576`), or a number with a binary suffix `K`, `M`, `G`, `T`
/// (optionally followed by `B` or `iB`, any case): `512M`, `8G`, `1.5GiB`.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let lower = t.to_ascii_lowercase();
    let body = lower.strip_suffix("ib").or_else(|| lower.strip_suffix('b')).unwrap_or(&lower);
    let (number, shift) = match body.chars().last() {
        Some('k') => (&body[..body.len() - 1], 10),
        Some('m') => (&body[..body.len() - 1], 20),
        Some('g') => (&body[..body.len() - 1], 30),
        Some('t') => (&body[..body.len() - 1], 40),
        _ => (body, 0),
    };
    let bad = || format!("`{s}` is not a size (bytes, or a number with K, M, G or T: 512M, 8G)");
    let number = number.trim();
    if number.is_empty() {
        return Err(bad());
    }
    if let Ok(n) = number.parse::<u64>() {
        return n.checked_mul(1u64 << shift).ok_or_else(bad);
    }
    match number.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 && v * ((1u64 << shift) as f64) < u64::MAX as f64 => {
            Ok((v * (1u64 << shift) as f64) as u64)
        }
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1024"), Ok(1024));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("8g"), Ok(8 << 30));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("2KB"), Ok(2048));
        assert_eq!(parse_size("1T"), Ok(1 << 40));
        for bad in ["", "G", "-1", "abc", "1X", "nan", "99999999999T"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
        assert_eq!(format_size(512), "512 B");
        assert_eq!(format_size(1 << 41), "2.0 TiB");
        assert_eq!(format_size(20 * (1 << 30) + (1 << 29)), "20.5 GiB");
        assert_eq!(parse_meminfo("MemTotal: 10 kB\nMemAvailable:   2048 kB\n"), Some(2 << 20));
        assert_eq!(parse_meminfo("MemTotal: 10 kB\n"), None);
    }

    #[test]
    fn limits() {
        assert_eq!(limit(Some(0), 1), Some((0, LimitSource::Explicit)));
        if let Some(a) = available() {
            let (bytes, _) = limit(None, 1).expect("a limit on Linux");
            assert!(bytes <= a);
            assert_eq!(limit(Some(u64::MAX), 1).map(|l| l.0), Some(bytes));
        }
    }

    #[test]
    fn rlimits_leave_room_for_the_current_size_and_thread_arenas() {
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max data size             unlimited            unlimited            bytes\n\
                      Max address space         1073741824           unlimited            bytes\n";
        let status = "VmPeak:\t 300000 kB\nVmSize:\t  102400 kB\nVmData:\t 50000 kB\n";
        let room = (1u64 << 30) - (100 << 20) - 3 * ARENA_RESERVE - 2 * STACK_RESERVE;
        assert_eq!(rlimit_headroom(limits, status, 2), Some(room));
        let unlimited = limits.replace("1073741824", "unlimited");
        assert_eq!(rlimit_headroom(&unlimited, status, 2), None);
        let data = unlimited.replacen("unlimited", "209715200", 1);
        assert_eq!(rlimit_headroom(&data, status, 0), Some((200 << 20) - 50_000 * 1024 - ARENA_RESERVE));
        let one = (200 << 20) - 50_000 * 1024 - 2 * ARENA_RESERVE - STACK_RESERVE;
        assert_eq!(rlimit_headroom(&data, status, 1), Some(one));
        // Over the limit already: no room at all, not a wrap-around.
        let tiny = limits.replace("1073741824", "1000");
        assert_eq!(rlimit_headroom(&tiny, status, 1), Some(0));
    }

    #[test]
    fn cgroup_limits_of_the_group_and_its_ancestors_in_either_version() {
        let files = |path: &str| -> Option<String> {
            Some(
                match path {
                    "/sys/fs/cgroup/job/step/memory.max" => "max\n",
                    "/sys/fs/cgroup/job/step/memory.current" => "1000\n",
                    "/sys/fs/cgroup/job/memory.max" => "1000000\n",
                    "/sys/fs/cgroup/job/memory.current" => "400000\n",
                    "/sys/fs/cgroup/memory/box/memory.limit_in_bytes" => "9223372036854771712\n",
                    "/sys/fs/cgroup/memory/memory.limit_in_bytes" => "500000\n",
                    "/sys/fs/cgroup/memory/memory.usage_in_bytes" => "200000\n",
                    _ => return None,
                }
                .to_string(),
            )
        };
        assert_eq!(cgroup_headroom("0::/job/step\n", files), Some(600_000), "v2: the ancestor's limit");
        assert_eq!(cgroup_headroom("4:memory:/box\n3:cpu:/\n", files), Some(300_000), "v1: the root's limit");
        assert_eq!(cgroup_headroom("0::/elsewhere\n", files), None);
        assert_eq!(cgroup_headroom("garbage", files), None);
    }
}
