//! The engine's error type: every failure names what went wrong and, for bad input, the field,
//! the value and the allowed range.

use std::path::PathBuf;

/// Returns the crate's result type, with [`Error`] as the error.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in sonarproj.
///
/// [`Error::is_input`] tells bad input (exit status 2 in the CLI) from other failures (status 1).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A value is outside its allowed range.
    #[error("{field} = {value} is invalid: {allowed}")]
    InvalidValue {
        /// Which field, with enough context to find it (e.g. `sonar "rig.toml": range_max`).
        field: String,
        /// The value as given.
        value: String,
        /// What is allowed instead.
        allowed: String,
    },
    /// An input is missing, or given together with one it excludes; said in words.
    #[error("{field}: {message}")]
    Input {
        /// Which input, with enough context to find it.
        field: String,
        /// What is wrong and what to give instead.
        message: String,
    },
    /// A sonar name is neither a preset nor an existing file.
    #[error("unknown sonar {name:?}: not a preset ({presets}) and no such file")]
    UnknownSonar {
        /// The name as given.
        name: String,
        /// The preset names, comma-separated.
        presets: String,
    },
    /// A sonar TOML file could not be parsed.
    #[error("sonar file {path}: {message}")]
    SonarFile {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// An input file could not be read.
    #[error("cannot read {path}: {source}")]
    ReadInput {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The GPU backend was asked for but no adapter exists.
    #[error(
        "no GPU adapter found (wgpu saw none{hint}); the CPU backends need none, the GPU path needs a Vulkan, Metal or DX12 driver (on Linux, apt-get install -y mesa-vulkan-drivers gives the software one, lavapipe)"
    )]
    NoAdapter {
        /// Extra words on what was tried.
        hint: String,
    },
    /// The GPU failed: a device that cannot be made, a shader or pipeline the driver refuses, a
    /// device lost, a mapping that failed, memory that ran out.
    #[error("GPU failure: {message}")]
    Gpu {
        /// What failed, with the cause's own words.
        message: String,
        /// The cause (wgpu's error), when there is one.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync + 'static>>,
    },
    /// The work was given up before its end because the caller's [`crate::stream::Stop`] was
    /// set ([`crate::Backend::project_until`]): a viewer client that went away, a Ctrl-C. A
    /// call that streams its results returns `Break` instead.
    #[error("stopped before the end, as asked")]
    Stopped,
}

impl Error {
    /// Returns true when the error is the caller's input (CLI exit status 2), false when it is a
    /// failure of the machine (status 1).
    #[must_use]
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Error::InvalidValue { .. }
                | Error::Input { .. }
                | Error::UnknownSonar { .. }
                | Error::SonarFile { .. }
                | Error::ReadInput { .. }
        )
    }

    /// Returns an [`Error::InvalidValue`] for `field`, `value` and the `allowed` text; a long
    /// value is quoted as an [`excerpt`].
    pub fn invalid(
        field: impl Into<String>,
        value: impl std::fmt::Display,
        allowed: impl Into<String>,
    ) -> Self {
        Error::InvalidValue {
            field: field.into(),
            value: shortened(&value.to_string()),
            allowed: allowed.into(),
        }
    }

    /// Returns an [`Error::Input`]: `field` is missing or given with one it excludes, as
    /// `message` says.
    pub fn input(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            field: field.into(),
            message: message.into(),
        }
    }

    /// Returns an [`Error::Gpu`]: `what` failed because of `cause`, which stays its source.
    pub fn gpu(what: &str, cause: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Gpu {
            message: format!("{what}: {cause}"),
            source: Some(Box::new(cause)),
        }
    }

    /// Returns an [`Error::Gpu`] without an underlying error (a limit of the device, said in
    /// `message`).
    pub fn gpu_limit(message: impl Into<String>) -> Self {
        Error::Gpu {
            message: message.into(),
            source: None,
        }
    }

    /// Returns the same error with `prefix: ` put in front of the field name (for nesting context).
    #[must_use]
    pub fn in_context(self, prefix: &str) -> Self {
        match self {
            Error::InvalidValue {
                field,
                value,
                allowed,
            } => Error::InvalidValue {
                field: format!("{prefix}: {field}"),
                value,
                allowed,
            },
            Error::Input { field, message } => Error::Input {
                field: format!("{prefix}: {field}"),
                message,
            },
            other => other,
        }
    }
}

/// Returns `text` quoted for an error message: whole when it has at most
/// [`EXCERPT_CHARS`](crate::limits::EXCERPT_CHARS) characters, else its beginning followed by `…`
/// and its length in bytes (a message never echoes a long piece of its input whole).
#[must_use]
pub fn excerpt(text: &str) -> String {
    let (head, mark) = cut(text, crate::limits::EXCERPT_CHARS);
    format!("{head:?}{mark}")
}

/// Returns `value` as an error shows it: a long number in exponent form (`1e308`), anything else
/// whole up to [`MAX_VALUE_CHARS`](crate::limits::MAX_VALUE_CHARS) characters, else cut there
/// and marked with its length.
fn shortened(value: &str) -> String {
    // A huge or tiny number formats with all its digits (1e308 has 309): say it as Rust reads it.
    if value.len() > 24
        && let Ok(v) = value.parse::<f64>()
        && v.is_finite()
    {
        return format!("{v:e}");
    }
    let (head, mark) = cut(value, crate::limits::MAX_VALUE_CHARS);
    format!("{head}{mark}")
}

/// Returns the first `chars` characters of `text` and, when it has more, the mark
/// `… (N bytes)` giving its whole length (empty otherwise).
fn cut(text: &str, chars: usize) -> (&str, String) {
    match text.char_indices().nth(chars) {
        None => (text, String::new()),
        Some((at, _)) => (&text[..at], format!("… ({} bytes)", text.len())),
    }
}

/// Returns a parser's multi-line message (a TOML error with the offending line and a caret)
/// with its lines kept and each cut to [`MAX_VALUE_CHARS`](crate::limits::MAX_VALUE_CHARS)
/// characters, so that a huge line of input is never echoed whole.
#[must_use]
pub fn parser_message(message: &str) -> String {
    message
        .trim_end()
        .lines()
        .map(shortened)
        .collect::<Vec<_>>()
        .join("\n")
}

/// Returns `Ok(v)` when `v` is finite, else an error naming `field`.
pub fn finite(field: &str, v: f64) -> Result<f64> {
    finite_named(|| field.to_string(), v)
}

/// Returns `v` when it is finite, else [`Error::InvalidValue`] for the field `field()` names;
/// the name is only built for the error (hot paths check every pose).
///
/// # Errors
/// [`Error::InvalidValue`] for NaN and infinities.
pub fn finite_named(field: impl FnOnce() -> String, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::invalid(field(), v, "must be a finite number"))
    }
}
