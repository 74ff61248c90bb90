//! Quake's tokenizer, shared by the `.map` parser and the entity-text parser
//! ([`crate::entities`]): whitespace-separated words, `"quoted strings"` and `//` comments, each
//! token with its 1-based line and column and its byte offset.
//!
//! Like Quake's own parsers, any byte `<= b' '` separates tokens, a `//` at the start of a token
//! comments out the rest of the line, and a quoted string runs to the next `"` (no escapes) on the
//! same line. Columns count characters, not bytes. Tokens borrow from the text, so the lexer never
//! allocates.

/// One token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Token<'a> {
    /// The text, without quotes for a quoted string.
    pub text: &'a str,
    /// Whether the token was a quoted string.
    pub quoted: bool,
    /// 1-based line.
    pub line: u32,
    /// 1-based column (in characters).
    pub col: u32,
    /// Byte offset of its first byte (the opening quote of a quoted string) in the text.
    pub offset: usize,
}

/// A lexing failure: an unterminated quoted string at `line:col`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Unterminated {
    /// 1-based line of the opening quote.
    pub line: u32,
    /// 1-based column of the opening quote.
    pub col: u32,
    /// Byte offset of the opening quote.
    pub offset: usize,
}

/// The tokenizer with one token of look-ahead.
#[derive(Debug)]
pub(crate) struct Lexer<'a> {
    text: &'a str,
    pos: usize,
    line: u32,
    col: u32,
    peeked: Option<Result<Option<Token<'a>>, Unterminated>>,
}

impl<'a> Lexer<'a> {
    /// A lexer at the start of `text` (a leading byte-order mark is skipped).
    pub fn new(text: &'a str) -> Self {
        let pos = if text.starts_with('\u{feff}') { '\u{feff}'.len_utf8() } else { 0 };
        Self { text, pos, line: 1, col: 1, peeked: None }
    }

    /// The line and column just past the last byte read (used to report end-of-file errors).
    #[cfg(feature = "map")]
    pub fn end_position(&self) -> (u32, u32) {
        (self.line, self.col)
    }

    /// The next token without consuming it; `Ok(None)` at end of input.
    #[cfg(feature = "map")]
    pub fn peek(&mut self) -> Result<Option<Token<'a>>, Unterminated> {
        if self.peeked.is_none() {
            self.peeked = Some(self.scan());
        }
        self.peeked.unwrap_or(Ok(None))
    }

    /// The next token; `Ok(None)` at end of input.
    pub fn next_token(&mut self) -> Result<Option<Token<'a>>, Unterminated> {
        match self.peeked.take() {
            Some(t) => t,
            None => self.scan(),
        }
    }

    /// Advance over one byte, keeping line and column.
    fn bump(&mut self, byte: u8) {
        self.pos += 1;
        if byte == b'\n' {
            self.line = self.line.saturating_add(1);
            self.col = 1;
        } else if byte & 0xC0 != 0x80 {
            // Count characters: UTF-8 continuation bytes do not start a new column.
            self.col = self.col.saturating_add(1);
        }
    }

    fn scan(&mut self) -> Result<Option<Token<'a>>, Unterminated> {
        let bytes = self.text.as_bytes();
        loop {
            while let Some(&b) = bytes.get(self.pos) {
                if b > b' ' {
                    break;
                }
                self.bump(b);
            }
            if bytes.get(self.pos) == Some(&b'/') && bytes.get(self.pos + 1) == Some(&b'/') {
                while let Some(&b) = bytes.get(self.pos) {
                    if b == b'\n' {
                        break;
                    }
                    self.bump(b);
                }
                continue;
            }
            break;
        }
        let Some(&first) = bytes.get(self.pos) else {
            return Ok(None);
        };
        let (line, col, offset) = (self.line, self.col, self.pos);
        if first == b'"' {
            self.bump(first);
            let start = self.pos;
            while let Some(&b) = bytes.get(self.pos) {
                if b == b'"' {
                    let text = self.text.get(start..self.pos).unwrap_or("");
                    self.bump(b);
                    return Ok(Some(Token { text, quoted: true, line, col, offset }));
                }
                if b == b'\n' {
                    break;
                }
                self.bump(b);
            }
            return Err(Unterminated { line, col, offset });
        }
        let start = self.pos;
        while let Some(&b) = bytes.get(self.pos) {
            if b <= b' ' {
                break;
            }
            self.bump(b);
        }
        // `start..pos` begins and ends at ASCII bytes or the end of text, so it is a char boundary.
        let text = self.text.get(start..self.pos).unwrap_or("");
        Ok(Some(Token { text, quoted: false, line, col, offset }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(text: &str) -> Vec<(String, bool, u32, u32)> {
        let mut lx = Lexer::new(text);
        let mut out = Vec::new();
        while let Some(t) = lx.next_token().unwrap() {
            out.push((t.text.to_string(), t.quoted, t.line, t.col));
        }
        out
    }

    #[test]
    fn words_strings_comments_and_positions() {
        let toks = all("// c\n{ \"a b\" \"\"\n  ( 1.5 -2 )// x\r\n\tTEX }");
        let expect = [
            ("{", false, 2, 1),
            ("a b", true, 2, 3),
            ("", true, 2, 9),
            ("(", false, 3, 3),
            ("1.5", false, 3, 5),
            ("-2", false, 3, 9),
            (")//", false, 3, 12),
            ("x", false, 3, 16),
            ("TEX", false, 4, 2),
            ("}", false, 4, 6),
        ];
        let got: Vec<_> = toks.iter().map(|(t, q, l, c)| (t.as_str(), *q, *l, *c)).collect();
        assert_eq!(got, expect);
    }

    #[test]
    fn columns_count_characters() {
        let toks = all("\"é\" x");
        assert_eq!(toks[1], ("x".to_string(), false, 1, 5));
        // Offsets count bytes.
        let mut lx = Lexer::new("\"é\" x");
        assert_eq!(lx.next_token().unwrap().map(|t| t.offset), Some(0));
        assert_eq!(lx.next_token().unwrap().map(|t| t.offset), Some(5));
    }

    #[test]
    fn unterminated_string_is_an_error() {
        let mut lx = Lexer::new("{\n  \"abc\n\"");
        assert!(lx.next_token().unwrap().is_some());
        assert_eq!(lx.next_token(), Err(Unterminated { line: 2, col: 3, offset: 4 }));
    }

    #[test]
    #[cfg(feature = "map")]
    fn peek_does_not_consume() {
        let mut lx = Lexer::new("a b");
        assert_eq!(lx.peek().unwrap().map(|t| t.text), Some("a"));
        assert_eq!(lx.next_token().unwrap().map(|t| t.text), Some("a"));
        assert_eq!(lx.next_token().unwrap().map(|t| t.text), Some("b"));
        assert_eq!(lx.peek().unwrap(), None);
    }
}
