//! The one error type of every reader and writer.

use std::fmt;

/// What went wrong, in the house taxonomy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The operating system refused (file missing, permission, disk full).
    Io,
    /// The input breaks its format's rules (bad header, truncated body, index out of range).
    Invalid,
    /// The input is valid but uses a feature octowrap does not read (or the output format cannot
    /// hold what is asked, e.g. faces in XYZ).
    Unsupported,
    /// The input asks for more than the [`Limits`](crate::Limits) allow, or more than its own size
    /// can justify (a header declaring 10^12 vertices in a 1 kB file).
    LimitExceeded,
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Io => "i/o error",
            Self::Invalid => "invalid",
            Self::Unsupported => "unsupported",
            Self::LimitExceeded => "limit exceeded",
        })
    }
}

/// Where in the input an error was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Location {
    /// Nowhere in particular (the whole file, or a file-system error).
    #[default]
    Unknown,
    /// A byte offset from the start of the (decompressed) input.
    Byte(u64),
    /// A 1-based line number in a text input.
    Line(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown => Ok(()),
            Self::Byte(b) => write!(f, "byte {b}"),
            Self::Line(l) => write!(f, "line {l}"),
        }
    }
}

/// A read or write failure: the file, where in it, what kind, and a message saying what was
/// expected and what was found.
///
/// Its `Display` says everything, the underlying error included, so [`std::error::Error::source`]
/// returns nothing: a caller printing the whole chain (`anyhow`'s `{:#}`) would otherwise print
/// the cause twice. The cause stays available in the `source` field.
#[derive(Debug)]
#[non_exhaustive]
pub struct Error {
    /// The file name as the user gave it (`<stdin>` / `<stdout>` for the standard streams);
    /// empty until the top-level call fills it in.
    pub file: String,
    /// The kind of failure.
    pub kind: ErrorKind,
    /// Where in the input.
    pub location: Location,
    /// What was expected and what was found.
    pub message: String,
    /// The underlying error, when there is one (already part of the `Display`).
    pub source: Option<Box<dyn std::error::Error + Send + Sync + 'static>>,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.file.is_empty() {
            write!(f, "{}: ", self.file)?;
        }
        if self.location != Location::Unknown {
            write!(f, "{}: ", self.location)?;
        }
        write!(f, "{}: {}", self.kind, self.message)?;
        if let Some(s) = self.source.as_ref().map(ToString::to_string).filter(|s| *s != self.message) {
            write!(f, " ({s})")?;
        }
        Ok(())
    }
}

impl std::error::Error for Error {}

impl Error {
    /// A new error of `kind` at `location`.
    pub fn new(kind: ErrorKind, location: Location, message: impl Into<String>) -> Self {
        Self { file: String::new(), kind, location, message: message.into(), source: None }
    }

    /// The input breaks its format at `location`.
    pub fn invalid(location: Location, message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Invalid, location, message)
    }

    /// The input uses a feature we do not read.
    pub fn unsupported(location: Location, message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Unsupported, location, message)
    }

    /// The input asks for more than allowed or justified.
    pub fn limit(location: Location, message: impl Into<String>) -> Self {
        Self::new(ErrorKind::LimitExceeded, location, message)
    }

    /// An operating-system error.
    pub fn io(err: std::io::Error) -> Self {
        let message = err.to_string();
        Self { source: Some(Box::new(err)), ..Self::new(ErrorKind::Io, Location::Unknown, message) }
    }

    /// Attaches an underlying cause.
    #[must_use]
    pub fn with_source(mut self, source: impl std::error::Error + Send + Sync + 'static) -> Self {
        self.source = Some(Box::new(source));
        self
    }

    /// Names the file, unless a file is already named (an error from a file that another file
    /// refers to, such as a scan listed in a `.conf`, keeps the inner name).
    #[must_use]
    pub fn in_file(mut self, file: impl Into<String>) -> Self {
        if self.file.is_empty() {
            self.file = file.into();
        }
        self
    }
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
