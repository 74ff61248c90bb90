//! Memory budgets: a job estimates what it will allocate before allocating it, and refuses
//! (with what it would need and why) when that is more than the machine has available or more
//! than the caller allows.
//!
//! The available memory is `MemAvailable` of `/proc/meminfo` on Linux; elsewhere there is no
//! limit but the caller's.

/// Bytes available to a new allocation: `MemAvailable` on Linux, `None` (no limit) elsewhere or
/// when it cannot be read.
pub fn available() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        use std::io::Read;
        // One read of a buffer the whole file fits (about 1.5 KB): `read_to_string` starts small
        // on a file whose size reads as 0 and took eight reads.
        let mut text = String::with_capacity(8192);
        std::fs::File::open("/proc/meminfo").ok()?.read_to_string(&mut text).ok()?;
        parse_meminfo(&text)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line["MemAvailable:".len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => Some(value.saturating_mul(1024)),
        None => Some(value),
        Some(_) => None,
    }
}

/// Where a limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// The memory the machine has available.
    Available,
    /// The caller's explicit maximum (`--max-memory`).
    Explicit,
}

impl std::fmt::Display for LimitSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LimitSource::Available => "available; see --max-memory",
            LimitSource::Explicit => "allowed by --max-memory",
        })
    }
}

/// The limit a job must fit: the smaller of `max` and the available memory, with where it comes
/// from; `None` when there is neither.
pub fn limit(max: Option<u64>) -> Option<(u64, LimitSource)> {
    let avail = available().map(|a| (a, LimitSource::Available));
    let explicit = max.map(|m| (m, LimitSource::Explicit));
    match (explicit, avail) {
        (Some(e), Some(a)) => Some(if a.0 < e.0 { a } else { e }),
        (e, a) => e.or(a),
    }
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
        assert_eq!(limit(Some(0)), Some((0, LimitSource::Explicit)));
        if let Some(a) = available() {
            assert_eq!(limit(None), Some((a, LimitSource::Available)));
            assert_eq!(limit(Some(u64::MAX)), Some((a, LimitSource::Available)));
        }
    }
}
