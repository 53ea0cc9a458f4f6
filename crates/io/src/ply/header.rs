//! The PLY header: format line, elements and their properties, up to `end_header`.

use crate::text::{Lines, truncated};
use crate::{Error, Location, Result};

/// A PLY scalar type. Both the old names (`uchar`, `float`, ...) and the sized ones (`uint8`,
/// `float32`, ...) are accepted; `int64`/`uint64` (not in the original description, but written
/// by some tools) too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &[u8]) -> Option<Self> {
        Some(match name {
            b"char" | b"int8" => Self::I8,
            b"uchar" | b"uint8" => Self::U8,
            b"short" | b"int16" => Self::I16,
            b"ushort" | b"uint16" => Self::U16,
            b"int" | b"int32" => Self::I32,
            b"uint" | b"uint32" => Self::U32,
            b"int64" | b"long" => Self::I64,
            b"uint64" | b"ulong" => Self::U64,
            b"float" | b"float32" => Self::F32,
            b"double" | b"float64" => Self::F64,
            _ => return None,
        })
    }

    /// Size in bytes in a binary body.
    pub(crate) fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
        }
    }

    /// Whether the type is an integer type.
    pub(crate) fn is_int(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// The value of `b` (exactly `size()` bytes) as `f64`.
    #[inline]
    pub(crate) fn read_f64(self, b: &[u8], be: bool) -> f64 {
        macro_rules! get {
            ($t:ty) => {{
                let a = b.try_into().unwrap_or_default();
                if be { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }
            }};
        }
        match self {
            Self::I8 => f64::from(b.first().map_or(0, |&v| v as i8)),
            Self::U8 => f64::from(b.first().copied().unwrap_or(0)),
            Self::I16 => f64::from(get!(i16)),
            Self::U16 => f64::from(get!(u16)),
            Self::I32 => f64::from(get!(i32)),
            Self::U32 => f64::from(get!(u32)),
            Self::I64 => get!(i64) as f64,
            Self::U64 => get!(u64) as f64,
            Self::F32 => f64::from(get!(f32)),
            Self::F64 => get!(f64),
        }
    }

    /// The value of `b` (exactly `size()` bytes) as an integer, for list counts and indices
    /// (`None` for float types and for `uint64` values beyond `i64`).
    #[inline]
    pub(crate) fn read_int(self, b: &[u8], be: bool) -> Option<i64> {
        macro_rules! get {
            ($t:ty) => {{
                let a = b.try_into().ok()?;
                if be { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }
            }};
        }
        Some(match self {
            Self::I8 => i64::from(*b.first()? as i8),
            Self::U8 => i64::from(*b.first()?),
            Self::I16 => i64::from(get!(i16)),
            Self::U16 => i64::from(get!(u16)),
            Self::I32 => i64::from(get!(i32)),
            Self::U32 => i64::from(get!(u32)),
            Self::I64 => get!(i64),
            Self::U64 => i64::try_from(get!(u64)).ok()?,
            Self::F32 | Self::F64 => return None,
        })
    }
}

/// One property of an element.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Property {
    /// `property <type> <name>`
    Scalar { ty: Scalar, name: String },
    /// `property list <count type> <item type> <name>`
    List { count: Scalar, item: Scalar, name: String },
}

impl Property {
    /// The fewest bytes one value of this property takes in a binary body.
    pub(crate) fn min_binary_size(&self) -> usize {
        match self {
            Self::Scalar { ty, .. } => ty.size(),
            Self::List { count, .. } => count.size(),
        }
    }

    /// The most bytes one value of this property can take in a binary body (a list as long as its
    /// count type allows).
    pub(crate) fn max_binary_size(&self) -> u64 {
        match self {
            Self::Scalar { ty, .. } => ty.size() as u64,
            Self::List { count, item, .. } => {
                let most: u64 = match count {
                    Scalar::I8 => 127,
                    Scalar::U8 => 255,
                    Scalar::I16 => 32_767,
                    Scalar::U16 => 65_535,
                    Scalar::I32 => i32::MAX as u64,
                    Scalar::U32 => u64::from(u32::MAX),
                    _ => i64::MAX as u64,
                };
                (count.size() as u64).saturating_add(most.saturating_mul(item.size() as u64))
            }
        }
    }
}

/// An `element <name> <count>` and its properties.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Element {
    pub name: String,
    pub count: u64,
    pub props: Vec<Property>,
    /// Header line that declared it, for errors.
    pub line: u64,
}

impl Element {
    /// The record size when every property is a scalar (fixed-size binary records).
    pub(crate) fn fixed_size(&self) -> Option<usize> {
        self.props.iter().map(|p| matches!(p, Property::Scalar { .. }).then(|| p.min_binary_size())).sum()
    }

    /// The fewest bytes one record takes in a binary body.
    pub(crate) fn min_binary_size(&self) -> usize {
        self.props.iter().map(Property::min_binary_size).sum()
    }

    /// The most bytes one record can take in a binary body.
    pub(crate) fn max_binary_size(&self) -> u64 {
        self.props.iter().fold(0u64, |s, p| s.saturating_add(p.max_binary_size()))
    }
}

/// How the body is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Encoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// A parsed header.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Header {
    pub encoding: Encoding,
    pub elements: Vec<Element>,
    /// Byte offset of the first body byte.
    pub body_start: usize,
    /// Line number the body starts on (for ascii errors).
    pub body_line: u64,
}

fn found(t: Option<&[u8]>) -> String {
    t.map_or_else(|| "the end of the line".to_owned(), |t| format!("'{}'", String::from_utf8_lossy(truncated(t))))
}

/// Parses the header at the start of `data`.
pub(crate) fn parse(data: &[u8]) -> Result<Header> {
    let mut lines = Lines::new(data);
    match lines.next_line() {
        Some(l) if l.trim_ascii() == b"ply" => {}
        other => {
            return Err(Error::invalid(
                Location::Line(1),
                format!("expected the PLY signature 'ply' on the first line, found {}", found(other)),
            ));
        }
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(line) = lines.next_line() else {
            return Err(lines.invalid("expected 'end_header', found the end of the input"));
        };
        let mut toks = crate::text::tokens(line);
        let Some(keyword) = toks.next() else { continue };
        match keyword {
            b"comment" | b"obj_info" => {}
            b"format" => {
                encoding = Some(match toks.next() {
                    Some(b"ascii") => Encoding::Ascii,
                    Some(b"binary_little_endian") => Encoding::BinaryLe,
                    Some(b"binary_big_endian") => Encoding::BinaryBe,
                    t => {
                        return Err(lines.invalid(format!(
                            "expected 'ascii', 'binary_little_endian' or 'binary_big_endian' after 'format', found {}",
                            found(t)
                        )));
                    }
                });
                match toks.next() {
                    Some(b"1.0" | b"1") | None => {}
                    Some(v) => {
                        return Err(Error::unsupported(
                            lines.location(),
                            format!("PLY version {} (only 1.0 is defined)", String::from_utf8_lossy(truncated(v))),
                        ));
                    }
                }
            }
            b"element" => {
                let name = toks.next().ok_or_else(|| lines.invalid("expected an element name after 'element'"))?;
                let count = toks.next();
                let count = count.and_then(|c| std::str::from_utf8(c).ok()?.parse::<u64>().ok()).ok_or_else(|| {
                    lines.invalid(format!("expected a non-negative element count, found {}", found(count)))
                })?;
                elements.push(Element {
                    name: String::from_utf8_lossy(name).into_owned(),
                    count,
                    props: Vec::new(),
                    line: lines.line_number(),
                });
            }
            b"property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(lines.invalid("found 'property' before any 'element'"));
                };
                let scalar = |t: Option<&[u8]>| {
                    t.and_then(Scalar::parse).ok_or_else(|| {
                        lines.invalid(format!(
                            "expected a property type (char, uchar, short, ushort, int, uint, float, double, \
                             int8 .. float64), found {}",
                            found(t)
                        ))
                    })
                };
                let first = toks.next();
                let prop = if first == Some(b"list") {
                    let count = scalar(toks.next())?;
                    if !count.is_int() {
                        return Err(lines.invalid("a list count type must be an integer type"));
                    }
                    let item = scalar(toks.next())?;
                    let name = toks.next().ok_or_else(|| lines.invalid("expected a property name"))?;
                    Property::List { count, item, name: String::from_utf8_lossy(name).into_owned() }
                } else {
                    let ty = scalar(first)?;
                    let name = toks.next().ok_or_else(|| lines.invalid("expected a property name"))?;
                    Property::Scalar { ty, name: String::from_utf8_lossy(name).into_owned() }
                };
                element.props.push(prop);
            }
            b"end_header" => break,
            other => {
                return Err(lines.invalid(format!(
                    "expected a header keyword (format, element, property, comment, obj_info, end_header), found '{}'",
                    String::from_utf8_lossy(truncated(other))
                )));
            }
        }
    }
    let encoding = encoding.ok_or_else(|| lines.invalid("the header has no 'format' line"))?;
    Ok(Header { encoding, elements, body_start: lines.offset(), body_line: lines.line_number() + 1 })
}
