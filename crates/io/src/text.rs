//! Text inputs: a line cursor and a token cursor, both tracking line numbers for errors, and fast
//! number parsers.
//!
//! The float parsers take the exact fast path of Clinger (*How to read floating point numbers
//! accurately*, PLDI 1990): a decimal whose digits form an integer below 2^53 (`f64`) or 2^24
//! (`f32`), with a small power-of-ten exponent, is one exactly-representable integer times or divided by an
//! exactly-representable power of ten, so a single correctly rounded float operation gives the
//! correctly rounded result. Everything else (long mantissas, large exponents, `nan`, `inf`)
//! falls back to the standard library's parser, which is also correctly rounded. Either way the
//! result is the nearest float to the decimal, so text round trips are exact.

use crate::{Error, Location, Result};

/// Walks the lines of a text input. Lines end at `\n`; a trailing `\r` is dropped.
pub(crate) struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Lines<'a> {
    /// Starts at the beginning of `data`.
    pub(crate) fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0, line: 0 }
    }

    /// The next line (without its terminator), or `None` at the end.
    pub(crate) fn next_line(&mut self) -> Option<&'a [u8]> {
        let rest = self.data.get(self.pos..)?;
        if rest.is_empty() {
            return None;
        }
        let end = memchr(b'\n', rest).unwrap_or(rest.len());
        self.pos += (end + 1).min(rest.len());
        self.line += 1;
        let mut l = rest.get(..end).unwrap_or(rest);
        if let [head @ .., b'\r'] = l {
            l = head;
        }
        Some(l)
    }

    /// The next line that is not blank and does not start with `comment` (after leading blanks).
    pub(crate) fn next_content_line(&mut self, comment: u8) -> Option<&'a [u8]> {
        while let Some(l) = self.next_line() {
            let t = l.trim_ascii_start();
            if t.first().is_some_and(|&c| c != comment) {
                return Some(l);
            }
        }
        None
    }

    /// The location of the line last returned.
    pub(crate) fn location(&self) -> Location {
        Location::Line(self.line.max(1))
    }

    /// The 1-based number of the line last returned (0 before the first).
    pub(crate) fn line_number(&self) -> u64 {
        self.line
    }

    /// Byte offset of the first byte not yet returned.
    pub(crate) fn offset(&self) -> usize {
        self.pos
    }

    /// Bytes not yet returned.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    /// An "invalid" error at the current line.
    pub(crate) fn invalid(&self, message: impl Into<String>) -> Error {
        Error::invalid(self.location(), message)
    }
}

/// Walks the whitespace-separated tokens of a text input, ignoring line structure but counting
/// lines for errors (the ascii PLY body is a token stream).
pub(crate) struct Tokens<'a> {
    data: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Tokens<'a> {
    /// Starts at byte `pos` of `data`, which is on line `line` (1-based).
    pub(crate) fn new(data: &'a [u8], pos: usize, line: u64) -> Self {
        Self { data, pos, line }
    }

    /// The next token, or `None` at the end of the input.
    #[inline]
    pub(crate) fn next_token(&mut self) -> Option<&'a [u8]> {
        let data = self.data;
        let mut p = self.pos;
        while let Some(&c) = data.get(p) {
            if c > b' ' {
                break;
            }
            if c == b'\n' {
                self.line += 1;
            }
            p += 1;
        }
        let start = p;
        while let Some(&c) = data.get(p) {
            if c <= b' ' {
                break;
            }
            p += 1;
        }
        self.pos = p;
        if p == start { None } else { data.get(start..p) }
    }

    /// The next token if it is a plain unsigned decimal below 10^18, read in one pass (the fast
    /// path for face indices). Otherwise `None`, with only the whitespace before the token
    /// consumed, so that a general parser can take the token and explain what is wrong.
    #[inline]
    pub(crate) fn plain_uint(&mut self) -> Option<u64> {
        let data = self.data;
        let mut p = self.pos;
        while let Some(&c) = data.get(p) {
            if c > b' ' {
                break;
            }
            if c == b'\n' {
                self.line += 1;
            }
            p += 1;
        }
        self.pos = p;
        let start = p;
        let mut v: u64 = 0;
        while let Some(&c) = data.get(p) {
            let d = c.wrapping_sub(b'0');
            if d > 9 {
                break;
            }
            v = v * 10 + u64::from(d);
            p += 1;
            if p - start > 18 {
                return None;
            }
        }
        if p == start || data.get(p).is_some_and(|&c| c > b' ') {
            return None;
        }
        self.pos = p;
        Some(v)
    }

    /// Skips the rest of the current line.
    pub(crate) fn skip_line(&mut self) {
        let rest = self.data.get(self.pos..).unwrap_or_default();
        match memchr(b'\n', rest) {
            Some(i) => {
                self.pos += i + 1;
                self.line += 1;
            }
            None => self.pos = self.data.len(),
        }
    }

    /// The line the cursor is on.
    pub(crate) fn location(&self) -> Location {
        Location::Line(self.line.max(1))
    }

    /// Bytes not yet read.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn missing(&self, what: &str, tok: Option<&[u8]>, kind: &str) -> Error {
        match tok {
            Some(t) => Error::invalid(
                self.location(),
                format!("expected {kind} for {what}, found '{}'", String::from_utf8_lossy(truncated(t))),
            ),
            None => Error::invalid(self.location(), format!("expected {kind} for {what}, found the end of the input")),
        }
    }

    /// The next token as `f64`.
    #[inline]
    pub(crate) fn f64(&mut self, what: &str) -> Result<f64> {
        let t = self.next_token();
        t.and_then(parse_f64).ok_or_else(|| self.missing(what, t, "a number"))
    }

    /// The next token as `f32` (rounded once, directly from the decimal).
    #[inline]
    pub(crate) fn f32(&mut self, what: &str) -> Result<f32> {
        let t = self.next_token();
        t.and_then(parse_f32).ok_or_else(|| self.missing(what, t, "a number"))
    }

    /// The next token as a signed integer.
    #[inline]
    pub(crate) fn int(&mut self, what: &str) -> Result<i64> {
        let t = self.next_token();
        t.and_then(parse_i64).ok_or_else(|| self.missing(what, t, "an integer"))
    }
}

/// At most 40 bytes of a token, for error messages.
pub(crate) fn truncated(t: &[u8]) -> &[u8] {
    t.get(..40).unwrap_or(t)
}

fn memchr(needle: u8, hay: &[u8]) -> Option<usize> {
    hay.iter().position(|&b| b == needle)
}

/// Whitespace-separated tokens of a line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace).filter(|t| !t.is_empty())
}

/// A line without its `#` comment, if it has one.
pub(crate) fn strip_comment(line: &[u8]) -> &[u8] {
    match memchr(b'#', line) {
        Some(i) => line.get(..i).unwrap_or(line),
        None => line,
    }
}

/// A decimal split into its parts: `(-1)^neg * mantissa * 10^exp10`.
struct Decimal {
    neg: bool,
    mantissa: u64,
    exp10: i32,
}

/// Splits a plain decimal (`-12.5e-3`), or `None` for anything else (including more than 19
/// digits or an exponent beyond 4 digits), leaving those to the standard parser.
#[inline]
fn split_decimal(tok: &[u8]) -> Option<Decimal> {
    let (neg, mut rest) = match tok.split_first()? {
        (b'-', r) => (true, r),
        (b'+', r) => (false, r),
        _ => (false, tok),
    };
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut seen_digit = false;
    while let Some((&c, r)) = rest.split_first() {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        seen_digit = true;
        if mantissa != 0 || d != 0 {
            digits += 1;
        }
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        rest = r;
    }
    let mut exp10: i32 = 0;
    if let Some((b'.', r)) = rest.split_first() {
        rest = r;
        while let Some((&c, r)) = rest.split_first() {
            let d = c.wrapping_sub(b'0');
            if d > 9 {
                break;
            }
            seen_digit = true;
            if mantissa != 0 || d != 0 {
                digits += 1;
            }
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            exp10 -= 1;
            rest = r;
            if exp10 < -400 {
                return None;
            }
        }
    }
    if !seen_digit || digits > 19 {
        return None;
    }
    if let Some((b'e' | b'E', r)) = rest.split_first() {
        rest = r;
        let (eneg, r) = match rest.split_first()? {
            (b'-', r) => (true, r),
            (b'+', r) => (false, r),
            _ => (false, rest),
        };
        rest = r;
        let mut e: i32 = 0;
        let mut n = 0;
        while let Some((&c, r)) = rest.split_first() {
            let d = c.wrapping_sub(b'0');
            if d > 9 || n >= 4 {
                return None;
            }
            e = e * 10 + i32::from(d);
            n += 1;
            rest = r;
        }
        if n == 0 {
            return None;
        }
        exp10 += if eneg { -e } else { e };
    }
    if !rest.is_empty() {
        return None;
    }
    Some(Decimal { neg, mantissa, exp10 })
}

const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// Parses a decimal floating-point token (`nan` and `inf` included, as Rust spells them),
/// correctly rounded.
#[inline]
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    if let Some(d) = split_decimal(tok) {
        if let (true, Some(&p)) = (d.mantissa <= 1 << 53, POW10_F64.get(d.exp10.unsigned_abs() as usize)) {
            let m = d.mantissa as f64;
            let v = if d.exp10 < 0 { m / p } else { m * p };
            return Some(if d.neg { -v } else { v });
        }
    }
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses a decimal floating-point token to `f32`, correctly rounded (not through `f64`, which
/// could round twice).
#[inline]
pub(crate) fn parse_f32(tok: &[u8]) -> Option<f32> {
    if let Some(d) = split_decimal(tok) {
        if let (true, Some(&p)) = (d.mantissa <= 1 << 24, POW10_F32.get(d.exp10.unsigned_abs() as usize)) {
            let m = d.mantissa as f32;
            let v = if d.exp10 < 0 { m / p } else { m * p };
            return Some(if d.neg { -v } else { v });
        }
    }
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses a signed decimal integer token.
#[inline]
pub(crate) fn parse_i64(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.split_first()? {
        (b'-', r) => (true, r),
        (b'+', r) => (false, r),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 18 {
        return std::str::from_utf8(tok).ok()?.parse().ok();
    }
    let mut v: i64 = 0;
    for &c in digits {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + i64::from(d);
    }
    Some(if neg { -v } else { v })
}

/// Parses the next token of `it` as `f64`, or explains what was expected at `lines`' position.
pub(crate) fn expect_f64<'a>(it: &mut impl Iterator<Item = &'a [u8]>, what: &str, lines: &Lines<'_>) -> Result<f64> {
    match it.next() {
        Some(t) => parse_f64(t).ok_or_else(|| {
            lines.invalid(format!("expected a number for {what}, found '{}'", String::from_utf8_lossy(truncated(t))))
        }),
        None => Err(lines.invalid(format!("expected a number for {what}, found the end of the line"))),
    }
}

/// Parses the next token of `it` as `f32`, or explains what was expected at `lines`' position.
pub(crate) fn expect_f32<'a>(it: &mut impl Iterator<Item = &'a [u8]>, what: &str, lines: &Lines<'_>) -> Result<f32> {
    match it.next() {
        Some(t) => parse_f32(t).ok_or_else(|| {
            lines.invalid(format!("expected a number for {what}, found '{}'", String::from_utf8_lossy(truncated(t))))
        }),
        None => Err(lines.invalid(format!("expected a number for {what}, found the end of the line"))),
    }
}

/// Converts a colour component to 8 bits: a token written as an integer is taken as 0-255, one
/// written with a decimal point or exponent as 0.0-1.0 (the Geomview OFF convention).
pub(crate) fn color_component(tok: &[u8]) -> Option<u8> {
    let v = parse_f64(tok)?;
    let is_float = tok.iter().any(|&c| matches!(c, b'.' | b'e' | b'E' | b'n' | b'N' | b'i' | b'I'));
    Some(if is_float { unit_to_u8(v) } else { v.clamp(0.0, 255.0) as u8 })
}

/// Maps 0.0-1.0 to 0-255, rounding, clamping (NaN maps to 0).
pub(crate) fn unit_to_u8(v: f64) -> u8 {
    (v * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Text output built line by line and handed to the writer in chunks of about 64 kB, shared by
/// the text writers. Write into it with `write!` (writing to memory cannot fail), then end each
/// line with [`LineWriter::end_line`].
pub(crate) struct LineWriter<'w> {
    buf: String,
    out: &'w mut dyn std::io::Write,
}

impl<'w> LineWriter<'w> {
    pub(crate) fn new(out: &'w mut dyn std::io::Write) -> Self {
        Self { buf: String::with_capacity(1 << 16), out }
    }

    /// Ends the current line, passing the buffer on once it is full.
    pub(crate) fn end_line(&mut self) -> Result<()> {
        self.buf.push('\n');
        if self.buf.len() > 60_000 { self.flush() } else { Ok(()) }
    }

    fn flush(&mut self) -> Result<()> {
        self.out.write_all(self.buf.as_bytes()).map_err(Error::io)?;
        self.buf.clear();
        Ok(())
    }

    /// Writes what is left.
    pub(crate) fn finish(mut self) -> Result<()> {
        self.flush()
    }

    /// Faces as lines `n i j k ...`, as OFF and ascii PLY store them.
    pub(crate) fn counted_faces(&mut self, faces: &octowrap_mesh::FaceList) -> Result<()> {
        use std::fmt::Write as _;
        for f in faces.iter() {
            let _ = write!(self.buf, "{}", f.len());
            for i in f {
                let _ = write!(self.buf, " {i}");
            }
            self.end_line()?;
        }
        Ok(())
    }
}

impl std::fmt::Write for LineWriter<'_> {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.buf.push_str(s);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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

    #[test]
    fn token_cursor_counts_lines() {
        let mut t = Tokens::new(b"1 2\n\n 3\r\nx", 0, 1);
        assert_eq!(t.int("a").unwrap(), 1);
        assert_eq!(t.f64("b").unwrap().to_bits(), 2.0f64.to_bits());
        assert_eq!(t.f32("c").unwrap().to_bits(), 3.0f32.to_bits());
        assert_eq!(t.plain_uint(), None);
        let e = t.f64("d").unwrap_err();
        assert_eq!(e.location, Location::Line(4));
        assert!(e.message.contains("found 'x'"), "{e}");
        assert!(t.f64("e").unwrap_err().message.contains("end of the input"));
        let mut t = Tokens::new(b" 12\n7x -3 99999999999999999999 4", 0, 1);
        assert_eq!(t.plain_uint(), Some(12));
        assert_eq!(t.plain_uint(), None);
        assert_eq!(t.next_token(), Some(&b"7x"[..]));
        assert_eq!(t.location(), Location::Line(2));
        assert_eq!(t.plain_uint(), None);
        assert_eq!(t.int("i").unwrap(), -3);
        assert_eq!(t.plain_uint(), None);
        assert!(t.int("j").is_err());
        assert_eq!(t.plain_uint(), Some(4));
        assert_eq!(t.plain_uint(), None);
    }

    #[test]
    fn float_edge_cases() {
        for s in [
            "0",
            "-0",
            "1.",
            ".5",
            "+2",
            "1e5",
            "1E-5",
            "123456789012345678",
            "0.1",
            "3.4028235e38",
            "1e400",
            "1e-400",
            "nan",
            "inf",
            "-inf",
            "4.9e-324",
            "0.000000000000000000000000001",
            "9007199254740993",
        ] {
            let want64: f64 = s.parse().unwrap();
            let got64 = parse_f64(s.as_bytes()).unwrap();
            assert!(got64.to_bits() == want64.to_bits() || (want64.is_nan() && got64.is_nan()), "{s}");
            let want32: f32 = s.parse().unwrap();
            let got32 = parse_f32(s.as_bytes()).unwrap();
            assert!(got32.to_bits() == want32.to_bits() || (want32.is_nan() && got32.is_nan()), "{s}");
        }
        for s in ["", "-", ".", "e5", "1e", "1e+", "1.2.3", "--1", "1x", "0x10"] {
            assert_eq!(parse_f64(s.as_bytes()), s.parse::<f64>().ok(), "{s:?}");
        }
        assert_eq!(parse_i64(b"99999999999999999999"), None);
        assert_eq!(parse_i64(b"-"), None);
        assert_eq!(parse_i64(b"1.5"), None);
        assert_eq!(color_component(b"255"), Some(255));
        assert_eq!(color_component(b"1.0"), Some(255));
        assert_eq!(color_component(b"0.5"), Some(128));
    }

    proptest! {
        #[test]
        fn parsers_agree_with_std_on_any_f64(v in any::<f64>()) {
            for s in [format!("{v}"), format!("{v:e}"), format!("{v:.3}")] {
                let want: f64 = s.parse().unwrap();
                let got = parse_f64(s.as_bytes()).unwrap();
                prop_assert!(got.to_bits() == want.to_bits() || want.is_nan(), "{}", s);
            }
        }

        #[test]
        fn parsers_agree_with_std_on_any_f32(v in any::<f32>()) {
            for s in [format!("{v}"), format!("{v:e}"), format!("{v:.4}")] {
                let want: f32 = s.parse().unwrap();
                let got = parse_f32(s.as_bytes()).unwrap();
                prop_assert!(got.to_bits() == want.to_bits() || want.is_nan(), "{}", s);
            }
        }

        #[test]
        fn parsers_agree_with_std_on_any_text(s in "[-+0-9.eE]{0,12}") {
            prop_assert_eq!(parse_f64(s.as_bytes()).map(f64::to_bits), s.parse::<f64>().ok().map(f64::to_bits));
            prop_assert_eq!(parse_f32(s.as_bytes()).map(f32::to_bits), s.parse::<f32>().ok().map(f32::to_bits));
            prop_assert_eq!(parse_i64(s.as_bytes()), s.parse::<i64>().ok());
        }
    }
}

/// Helpers shared by the format modules' tests.
#[cfg(test)]
pub(crate) mod testing {
    use octowrap_geom::{DVec3, Vec3};
    use octowrap_mesh::{FaceList, Mesh};
    use proptest::prelude::*;

    use crate::{ReadOptions, Result};

    /// Every strict prefix of `data` must either parse or fail with an error; none may panic
    /// (a panic fails the test). Returns how many prefixes parsed.
    pub(crate) fn every_prefix(data: &[u8], read: impl Fn(&[u8], &ReadOptions) -> Result<Mesh>) -> usize {
        let opts = ReadOptions::default();
        (0..data.len()).filter(|&n| read(&data[..n], &opts).is_ok()).count()
    }

    /// `sample` with 1-8 random edits (a byte replaced, inserted or removed), the bytes biased
    /// towards digits, signs and separators so that counts and indices change meaningfully.
    pub(crate) fn mutated(sample: &'static [u8]) -> impl Strategy<Value = Vec<u8>> {
        let byte = prop_oneof![any::<u8>(), prop::sample::select(b"0123456789 -\n.e+#/\\".to_vec())];
        prop::collection::vec((any::<prop::sample::Index>(), byte, 0u8..3), 1..8).prop_map(move |edits| {
            let mut d = sample.to_vec();
            for (i, b, op) in edits {
                let k = i.index(d.len() + 1);
                match op {
                    0 if k < d.len() => d[k] = b,
                    1 => d.insert(k, b),
                    _ if k < d.len() => {
                        d.remove(k);
                    }
                    _ => {}
                }
            }
            d
        })
    }

    /// A random mesh: 0-12 vertices with optional attributes, and polygons of 3-6 corners.
    pub(crate) fn arb_mesh(attributes: bool, faces: bool) -> impl Strategy<Value = Mesh> {
        let coord = prop_oneof![
            (-1000i32..1000).prop_map(|v| f64::from(v) / 8.0),
            any::<f32>().prop_filter("finite", |v| v.is_finite()).prop_map(f64::from),
            (-1.0e7f64..1.0e7),
        ];
        let vertex = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| DVec3::new(x, y, z));
        (prop::collection::vec(vertex, 1..12), any::<[bool; 3]>(), any::<u64>(), 0usize..6).prop_map(
            move |(positions, has, seed, nfaces)| {
                let n = positions.len();
                let mut m = Mesh::from_positions(positions);
                let mut r = seed | 1;
                let mut next = move || {
                    r ^= r << 13;
                    r ^= r >> 7;
                    r ^= r << 17;
                    r
                };
                if attributes && has[0] {
                    m.vertices.normals = Some(
                        (0..n).map(|_| Vec3::new(next() as f32 / 1e19, -0.5, (next() % 1000) as f32 / 7.0)).collect(),
                    );
                }
                if attributes && has[1] {
                    m.vertices.colors = Some((0..n).map(|_| [next() as u8, next() as u8, next() as u8]).collect());
                }
                if attributes && has[2] {
                    m.vertices.intensities = Some((0..n).map(|_| (next() % 65536) as f32 * 0.25).collect());
                }
                if faces {
                    m.faces = FaceList::default();
                    for _ in 0..nfaces {
                        let k = 3 + (next() % 4) as usize;
                        m.faces.push_iter((0..k).map(|_| (next() % n as u64) as u32));
                    }
                }
                m
            },
        )
    }
}
