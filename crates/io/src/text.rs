//! Line-by-line access to text inputs, tracking line numbers and byte offsets for errors.

use crate::{Error, Location, Result};

/// Walks the lines of a text input. Lines end at `\n`; a trailing `\r` is dropped.
pub(crate) struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Lines<'a> {
    /// Starts at byte `pos` of `data`, which is on line `line` (1-based).
    pub(crate) fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0, line: 0 }
    }

    /// The next line (without its terminator), or `None` at the end.
    pub(crate) fn next_line(&mut self) -> Option<&'a [u8]> {
        if self.pos >= self.data.len() {
            return None;
        }
        let rest = &self.data[self.pos..];
        let end = memchr(b'\n', rest).unwrap_or(rest.len());
        self.pos += (end + 1).min(rest.len());
        self.line += 1;
        let mut l = &rest[..end];
        if let [head @ .., b'\r'] = l {
            l = head;
        }
        Some(l)
    }

    /// The next line that is not blank and does not start with `comment` (after leading blanks).
    pub(crate) fn next_content_line(&mut self, comment: u8) -> Option<&'a [u8]> {
        while let Some(l) = self.next_line() {
            let t = l.trim_ascii_start();
            if !t.is_empty() && t[0] != comment {
                return Some(l);
            }
        }
        None
    }

    /// The location of the line last returned.
    pub(crate) fn location(&self) -> Location {
        Location::Line(self.line.max(1))
    }

    /// Byte offset of the first byte not yet returned.
    pub(crate) fn offset(&self) -> usize {
        self.pos
    }

    /// Bytes not yet returned.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// An "invalid" error at the current line.
    pub(crate) fn invalid(&self, message: impl Into<String>) -> Error {
        Error::invalid(self.location(), message)
    }
}

fn memchr(needle: u8, hay: &[u8]) -> Option<usize> {
    hay.iter().position(|&b| b == needle)
}

/// Whitespace-separated tokens of a line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace).filter(|t| !t.is_empty())
}

/// Parses a decimal floating-point token (`nan` and `inf` included, as Rust spells them).
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses a signed decimal integer token.
pub(crate) fn parse_i64(tok: &[u8]) -> Option<i64> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses the next token of `it` as `f64`, or explains what was expected at `lines`' position.
pub(crate) fn expect_f64<'a>(it: &mut impl Iterator<Item = &'a [u8]>, what: &str, lines: &Lines<'_>) -> Result<f64> {
    match it.next() {
        Some(t) => parse_f64(t).ok_or_else(|| {
            lines.invalid(format!("expected a number for {what}, found '{}'", String::from_utf8_lossy(t)))
        }),
        None => Err(lines.invalid(format!("expected a number for {what}, found the end of the line"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_and_locations() {
        let mut l = Lines::new(b"a b\r\n\n# c\n  d");
        assert_eq!(l.next_line(), Some(&b"a b"[..]));
        assert_eq!(l.location(), Location::Line(1));
        assert_eq!(l.next_content_line(b'#'), Some(&b"  d"[..]));
        assert_eq!(l.location(), Location::Line(4));
        assert_eq!(l.next_line(), None);
        assert_eq!(l.remaining(), 0);
        assert_eq!(tokens(b" 1  2\t3 ").collect::<Vec<_>>(), vec![&b"1"[..], b"2", b"3"]);
        assert_eq!(parse_f64(b"-1.5e3"), Some(-1500.0));
        assert_eq!(parse_i64(b"-7"), Some(-7));
        assert_eq!(parse_f64(b"x"), None);
    }
}
