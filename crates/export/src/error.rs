//! The export error, in the house taxonomy (`Invalid`, `Unsupported`, `LimitExceeded`, `Io`).

/// Why an export failed. `file` names the file concerned (the output for I/O errors; callers may
/// name the input with [`Error::in_file`]); it is empty when no file is involved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The input cannot be exported as asked (no faces, broken indices, non-finite positions, a
    /// level that does not exist, an option out of range).
    #[error("{}invalid: {message}", prefix(file))]
    Invalid {
        /// The file concerned, or empty.
        file: String,
        /// What was expected and what was found.
        message: String,
    },
    /// The output cannot be written in the form asked (an extension other than `.glb`/`.gltf`).
    #[error("{}unsupported: {message}", prefix(file))]
    Unsupported {
        /// The file concerned, or empty.
        file: String,
        /// What was asked.
        message: String,
    },
    /// The result would not fit the container (GLB lengths are 32-bit).
    #[error("{}limit exceeded: {message}", prefix(file))]
    LimitExceeded {
        /// The file concerned, or empty.
        file: String,
        /// Which limit.
        message: String,
    },
    /// The operating system refused.
    #[error("{}i/o error: {source}", prefix(file))]
    Io {
        /// The file concerned.
        file: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

fn prefix(file: &str) -> String {
    if file.is_empty() { String::new() } else { format!("{file}: ") }
}

impl Error {
    pub(crate) fn invalid(message: impl Into<String>) -> Self {
        Self::Invalid { file: String::new(), message: message.into() }
    }

    pub(crate) fn limit(message: impl Into<String>) -> Self {
        Self::LimitExceeded { file: String::new(), message: message.into() }
    }

    /// Names `name` as the file concerned, unless a file is already named.
    #[must_use]
    pub fn in_file(mut self, name: impl Into<String>) -> Self {
        let (Self::Invalid { file, .. }
        | Self::Unsupported { file, .. }
        | Self::LimitExceeded { file, .. }
        | Self::Io { file, .. }) = &mut self;
        if file.is_empty() {
            *file = name.into();
        }
        self
    }

    /// The file concerned, or an empty string.
    pub fn file(&self) -> &str {
        let (Self::Invalid { file, .. }
        | Self::Unsupported { file, .. }
        | Self::LimitExceeded { file, .. }
        | Self::Io { file, .. }) = self;
        file
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_file() {
        let e = Error::invalid("level 3 has no faces");
        assert_eq!(e.to_string(), "invalid: level 3 has no faces");
        let e = e.in_file("dragon.mrq").in_file("ignored");
        assert_eq!(e.file(), "dragon.mrq");
        assert_eq!(e.to_string(), "dragon.mrq: invalid: level 3 has no faces");
    }
}
