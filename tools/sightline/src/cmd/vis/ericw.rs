//! The command line of ericw-tools' and id's `vis`, as TrenchBroom compile profiles and build
//! scripts pass it: a base name (`e1m1` reads `e1m1.bsp`, see [`super::resolve_input`]) and
//! single-dash options anywhere on the line. Before clap parses, [`ericw_args`] turns each one into
//! the `--` flag it means ([`ERICW_OPTIONS`]), drops those that only steer the reference tool's
//! logging, and rejects any other single-dash word.

use std::ffi::OsString;

/// What one option of ericw-tools' or id's `vis` becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EricwOption {
    /// A Sightline flag without a value.
    Flag(&'static str),
    /// A Sightline flag that takes the next word as its value.
    Value(&'static str),
    /// Accepted and ignored (logging and other reference-tool settings that change no output).
    Ignored,
    /// Accepted and ignored with the next word (its value).
    IgnoredWithValue,
    /// Accepted and ignored, and so is the next word when it is a number (`-lowpriority [0]`).
    IgnoredOptionalNumber,
}

/// The single-dash options `sightline vis` takes (names as ericw-tools spells them; matched
/// without regard to case), and what each becomes.
pub const ERICW_OPTIONS: &[(&str, EricwOption)] = &[
    ("threads", EricwOption::Value("--threads")),
    ("fast", EricwOption::Flag("--fast")),
    ("level", EricwOption::Value("--level")),
    ("visdist", EricwOption::Value("--farplane")),
    ("farplane", EricwOption::Value("--farplane")),
    ("noambient", EricwOption::Flag("--no-ambient")),
    ("noambientsky", EricwOption::Flag("--no-ambient-sky")),
    ("noambientwater", EricwOption::Flag("--no-ambient-water")),
    ("noambientslime", EricwOption::Flag("--no-ambient-slime")),
    ("noambientlava", EricwOption::Flag("--no-ambient-lava")),
    ("nostate", EricwOption::Flag("--no-state")),
    ("noprogress", EricwOption::Flag("--no-progress")),
    ("help", EricwOption::Flag("--help")),
    // ericw-tools: "-quiet / -noverbose: -nopercent -nostat -noprogress".
    ("quiet", EricwOption::Flag("--no-progress")),
    ("noverbose", EricwOption::Flag("--no-progress")),
    ("nopercent", EricwOption::Ignored),
    ("nostat", EricwOption::Ignored),
    ("v", EricwOption::Ignored),
    ("vv", EricwOption::Ignored),
    ("verbose", EricwOption::Ignored),
    ("log", EricwOption::Ignored),
    ("nolog", EricwOption::Ignored),
    ("nocolor", EricwOption::Ignored),
    ("autoclean", EricwOption::Ignored),
    ("noautoclean", EricwOption::Ignored),
    ("defaultpaths", EricwOption::Ignored),
    ("nodefaultpaths", EricwOption::Ignored),
    ("lowpriority", EricwOption::IgnoredOptionalNumber),
    // Game and search paths: ericw-tools' vis reads no texture through them for Quake maps.
    ("gamedir", EricwOption::IgnoredWithValue),
    ("basedir", EricwOption::IgnoredWithValue),
    ("path", EricwOption::IgnoredWithValue),
    ("filepriority", EricwOption::IgnoredWithValue),
];

/// The arguments after `vis` with ericw-tools / id single-dash options turned into Sightline's
/// (see [`ERICW_OPTIONS`]). Everything else passes through unchanged: `--` flags (with the next
/// word when `long_takes_value` says the flag takes one and it is not given as `--flag=value`),
/// the short flags in `shorts` (clap's, such as `-h`), numbers, and every word after `--`.
/// Errors name an unknown single-dash word, or an option missing its value.
pub fn ericw_args(
    words: &[OsString],
    long_takes_value: &dyn Fn(&str) -> bool,
    shorts: &[char],
) -> Result<Vec<OsString>, String> {
    let mut out = Vec::with_capacity(words.len());
    let mut i = 0;
    while i < words.len() {
        let word = &words[i];
        i += 1;
        let Some(s) = word.to_str() else {
            out.push(word.clone());
            continue;
        };
        if s == "--" {
            out.extend(words[i - 1..].iter().cloned());
            break;
        }
        if let Some(long) = s.strip_prefix("--") {
            out.push(word.clone());
            if !long.contains('=') && long_takes_value(long) && i < words.len() {
                out.push(words[i].clone());
                i += 1;
            }
            continue;
        }
        let Some(name) = single_dash_name(s) else {
            out.push(word.clone());
            continue;
        };
        let mut chars = name.chars();
        if let (Some(c), None) = (chars.next(), chars.next())
            && shorts.contains(&c)
        {
            out.push(word.clone());
            continue;
        }
        let lower = name.to_ascii_lowercase();
        let Some(&(_, option)) = ERICW_OPTIONS.iter().find(|(n, _)| *n == lower) else {
            return Err(format!(
                "unknown vis option `{s}` (ericw-tools options such as -threads N, -fast, -level N, \
                 -noambient, -visdist N are taken; see `sightline vis --help`)"
            ));
        };
        let next = words.get(i);
        match option {
            EricwOption::Flag(long) => out.push(long.into()),
            EricwOption::Value(long) => {
                let Some(value) = next else { return Err(format!("vis option `{s}` needs a value")) };
                out.push(long.into());
                out.push(value.clone());
                i += 1;
            }
            EricwOption::Ignored => {}
            EricwOption::IgnoredWithValue => {
                if next.is_none() {
                    return Err(format!("vis option `{s}` needs a value"));
                }
                i += 1;
            }
            EricwOption::IgnoredOptionalNumber => {
                if next.and_then(|v| v.to_str()).is_some_and(|v| v.parse::<i64>().is_ok()) {
                    i += 1;
                }
            }
        }
    }
    Ok(out)
}

/// The name of a single-dash option word (`-threads` gives `threads`): a word after one `-` that
/// is not a number. `--` words are not (see [`ericw_args`]).
pub fn single_dash_name(word: &str) -> Option<&str> {
    word.strip_prefix('-').filter(|n| !n.is_empty() && !n.starts_with('-') && word.parse::<f64>().is_err())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn translate(words: &[&str]) -> Result<Vec<String>, String> {
        let words: Vec<OsString> = words.iter().map(OsString::from).collect();
        let takes_value = |long: &str| matches!(long, "threads" | "state" | "level" | "farplane");
        let out = ericw_args(&words, &takes_value, &['h', 'V'])?;
        Ok(out.into_iter().map(|w| w.into_string().expect("utf-8")).collect())
    }

    #[test]
    fn ericw_options_become_long_flags_and_the_rest_passes_through() {
        assert_eq!(
            translate(&["-threads", "4", "-Fast", "e1m1", "-level", "2", "-noambientsky", "-visdist", "900"]),
            Ok(["--threads", "4", "--fast", "e1m1", "--level", "2", "--no-ambient-sky", "--farplane", "900"]
                .map(String::from)
                .to_vec())
        );
        // Ignored options vanish, with their value where they take one.
        assert_eq!(
            translate(&[
                "-v",
                "-nolog",
                "-lowpriority",
                "1",
                "-basedir",
                "/q",
                "e1m1",
                "-lowpriority",
                "-nopercent"
            ]),
            Ok(vec!["e1m1".to_string()])
        );
        // Sightline's own flags and their values are never rewritten, nor anything after `--`;
        // clap's short flags and negative numbers pass.
        assert_eq!(
            translate(&["--state", "-odd-name", "--threads=2", "-h", "--", "-fast", "-x"]),
            Ok(["--state", "-odd-name", "--threads=2", "-h", "--", "-fast", "-x"].map(String::from).to_vec())
        );
        assert_eq!(translate(&["-farplane", "-5"]), Ok(vec!["--farplane".into(), "-5".into()]));
        assert_eq!(translate(&["-1.5"]), Ok(vec!["-1.5".into()]));
    }

    #[test]
    fn unknown_options_and_missing_values_are_errors_naming_them() {
        let err = translate(&["e1m1", "-bogus"]).expect_err("unknown");
        assert!(err.contains("`-bogus`"), "{err}");
        let err = translate(&["e1m1", "-threads"]).expect_err("no value");
        assert!(err.contains("`-threads`") && err.contains("value"), "{err}");
        assert!(translate(&["-gamedir"]).is_err());
        assert!(translate(&["-"]).is_ok(), "a lone dash is a word, not an option");
    }
}
