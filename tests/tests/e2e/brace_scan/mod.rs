//! An independent count of a `.map`'s entities, brushes and sides that knows only braces,
//! key/value lines and comments, to check the real parser against (shared by test files).

/// Counts found by a scan that knows only braces, quotes and comments.
#[derive(Debug, PartialEq, Eq, Default)]
pub struct BraceCounts {
    pub entities: usize,
    pub brushes: usize,
    pub sides: usize,
}

/// Count `{` tokens at depth 0 (entities) and at depth 1 (brushes), and lines at depth 2 whose first
/// token is `(` (sides). Key/value lines (starting with a quote) and `//` comments are skipped;
/// braces count only as whole whitespace-separated tokens, since texture names may contain them.
pub fn brace_scan(text: &str) -> BraceCounts {
    let mut counts = BraceCounts::default();
    let mut depth = 0usize;
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with('"') {
            continue;
        }
        let code = line.split("//").next().unwrap_or("");
        for (i, token) in code.split_whitespace().enumerate() {
            match token {
                "{" => {
                    match depth {
                        0 => counts.entities += 1,
                        1 => counts.brushes += 1,
                        _ => {}
                    }
                    depth += 1;
                }
                "}" => depth = depth.checked_sub(1).expect("the scan found an unmatched `}`"),
                "(" if depth == 2 && i == 0 => counts.sides += 1,
                _ => {}
            }
        }
    }
    assert_eq!(depth, 0, "the scan itself found unbalanced braces");
    counts
}
