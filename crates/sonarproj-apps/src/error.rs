//! The applications' error type: the engine's errors, plus what can go wrong reading and
//! writing files (sweep files, CSV tables, output files, figures).

use sonarproj::error::{Field, Param};
use std::path::PathBuf;

/// Returns the applications' result type, with [`Error`] as the error.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in the applications. [`Error::is_input`] tells bad input (CLI
/// exit status 2) from other failures (status 1).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error of the engine, such as an invalid value, a sonar file or the GPU.
    #[error(transparent)]
    Engine(#[from] sonarproj::Error),
    /// A sweep TOML file could not be parsed.
    #[error("sweep file {path}: {message}")]
    SweepFile {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// An advise TOML file could not be parsed.
    #[error("advise file {path}: {message}")]
    AdviseFile {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// A CSV input is malformed, in its header or one row.
    #[error("{context}: {message}")]
    Csv {
        /// Where: `input header` or `input row N (line L)`.
        context: String,
        /// What is wrong.
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
    /// An output file could not be written.
    #[error("cannot write {path}: {message}")]
    WriteOutput {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        message: String,
    },
    /// A figure could not be drawn.
    #[error("cannot draw a figure: {0}")]
    Figure(String),
    /// The viewer's web server failed: the address cannot be bound, or a reply cannot be sent.
    #[error("viewer server: {0}")]
    Serve(String),
    /// Some lines of a line-by-line input were bad. Each got its own error in the output.
    #[error("{bad} of {lines} input lines were bad; each has an \"error\" object in the output")]
    BadLines {
        /// The bad lines.
        bad: usize,
        /// All lines read.
        lines: usize,
    },
}

impl Error {
    /// Returns true when the error is the caller's input (CLI exit status 2), false when the
    /// machine failed (status 1).
    #[must_use]
    pub fn is_input(&self) -> bool {
        match self {
            Error::Engine(e) => e.is_input(),
            Error::SweepFile { .. }
            | Error::AdviseFile { .. }
            | Error::Csv { .. }
            | Error::ReadInput { .. }
            | Error::BadLines { .. } => true,
            Error::WriteOutput { .. } | Error::Figure(_) | Error::Serve(_) => false,
        }
    }

    /// Returns the engine's [`sonarproj::Error::InvalidValue`] for `field`, `value` and `allowed`.
    pub fn invalid(
        field: impl Into<Field>,
        value: impl std::fmt::Display,
        allowed: impl Into<String>,
    ) -> Self {
        Error::Engine(sonarproj::Error::invalid(field, value, allowed))
    }

    /// Returns an [`Error::WriteOutput`] for `path` failing with `e`.
    pub fn write_output(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Error::WriteOutput {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    }

    /// Returns the engine's [`sonarproj::Error::Input`]: `field` is missing, or given with another
    /// that it excludes, as `message` says.
    pub fn input(field: impl Into<Field>, message: impl Into<String>) -> Self {
        Error::Engine(sonarproj::Error::input(field, message))
    }

    /// Returns the same error with `prefix: ` before the field name of an invalid value. `prefix`
    /// is words or a front's [`Param`].
    #[must_use]
    pub fn in_context(self, prefix: impl Into<Field>) -> Self {
        match self {
            Error::Engine(e) => Error::Engine(e.in_context(prefix)),
            other => other,
        }
    }

    /// Returns the message with each front's input named by `name` ([`sonarproj::Error::render`]).
    /// This is how the command line and Python say one error in their own words.
    #[must_use]
    pub fn render(&self, name: &dyn Fn(Param) -> String) -> String {
        match self {
            Error::Engine(e) => e.render(name),
            other => other.to_string(),
        }
    }
}

/// Returns `Ok(v)` when `v` is finite, else an error naming `field`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for NaN and infinities.
pub fn finite(field: impl Into<Field>, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::invalid(field, v, "must be a finite number"))
    }
}
