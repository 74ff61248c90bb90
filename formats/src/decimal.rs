//! Decimal numbers in text files, read quickly when they are short.
//!
//! Compilers write coordinates as short decimals (`1584`, `-63.5`, `0.125`). Such a number has a
//! mantissa below 2⁵³ and at most 22 digits after the point, so both the mantissa and the power of
//! ten are exact `f64`s and one division gives the correctly rounded value, as the standard
//! parser would (Clinger's fast path). Everything else goes to the standard parser.

/// Exact powers of ten up to 10¹⁵ (the most digits [`parse_f64`] takes on its fast path).
const POW10: [f64; 16] =
    [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// The `f64` that `s.parse::<f64>()` gives, or `None` where that fails.
pub(crate) fn parse_f64(s: &str) -> Option<f64> {
    short(s.as_bytes()).or_else(|| s.parse().ok())
}

/// `[+-]digits[.digits]` (or `[+-].digits`) with at most 15 digits in all, else `None`.
fn short(b: &[u8]) -> Option<f64> {
    let (negative, digits) = match b.first()? {
        b'-' => (true, &b[1..]),
        b'+' => (false, &b[1..]),
        _ => (false, b),
    };
    let (mut mantissa, mut count, mut after) = (0u64, 0usize, None::<usize>);
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(c - b'0');
                count += 1;
                if count >= POW10.len() {
                    return None;
                }
            }
            b'.' if after.is_none() => after = Some(count),
            _ => return None,
        }
    }
    if count == 0 {
        return None;
    }
    // `mantissa` < 10¹⁵ < 2⁵³ is exact, and so is the power of ten it is divided by.
    let value = mantissa as f64 / POW10[count - after.unwrap_or(count)];
    Some(if negative { -value } else { value })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// Bit-identical to the standard parser, signs of zero included.
    fn same(s: &str) -> bool {
        match (parse_f64(s), s.parse::<f64>().ok()) {
            (Some(a), Some(b)) => a.to_bits() == b.to_bits(),
            (None, None) => true,
            _ => false,
        }
    }

    #[test]
    fn short_decimals_and_the_rest_read_as_the_standard_parser_reads_them() {
        for s in [
            "0",
            "-0",
            "+0",
            "-0.0",
            "1584",
            "-63.5",
            "0.125",
            "1.",
            ".5",
            "-.5",
            "+.5",
            ".",
            "-",
            "+",
            "",
            "1..2",
            "1.2.3",
            "007",
            "0.1",
            "0.3",
            "123456789012345",
            "1234567890123456",
            "99999999999999.9",
            "0.000000000000001",
            "1e5",
            "1E-3",
            "inf",
            "-inf",
            "nan",
            "NaN",
            "abc",
            "1 2",
            " 1",
            "1 ",
            "--1",
            "+-1",
            "4503599627370497",
            "9007199254740993",
            "0x10",
            "١",
        ] {
            assert!(same(s), "{s:?}: {:?} against {:?}", parse_f64(s), s.parse::<f64>());
        }
        assert!(short(b"1e5").is_none(), "exponents go to the standard parser");
    }

    proptest! {
        #[test]
        fn any_decimal_reads_as_the_standard_parser_reads_it(
            sign in prop::sample::select(vec!["", "-", "+"]),
            int in "[0-9]{0,12}",
            frac in prop::option::of("[0-9]{0,12}"),
        ) {
            let s = format!("{sign}{int}{}", frac.map(|f| format!(".{f}")).unwrap_or_default());
            prop_assert!(same(&s), "{s:?}");
        }

        #[test]
        fn any_float_written_shortest_reads_back_exactly(x in any::<f64>()) {
            let s = x.to_string();
            prop_assert!(same(&s), "{s:?}");
        }
    }
}
