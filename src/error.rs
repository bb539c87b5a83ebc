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
        field: Field,
        /// The value as given.
        value: String,
        /// What is allowed instead.
        allowed: String,
    },
    /// An input is missing, or given together with one it excludes; said in words.
    #[error("{field}: {message}")]
    Input {
        /// Which input, with enough context to find it.
        field: Field,
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
    /// set ([`crate::Backend::project_until`]): a viewer client that went away, a Ctrl-C. A call
    /// that streams its results returns `Break` instead.
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

    /// Returns an [`Error::InvalidValue`] for `field` (its name, or a front's [`Param`]), `value`
    /// and the `allowed` text. A long value is shortened, as every error shows values.
    pub fn invalid(
        field: impl Into<Field>,
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
    pub fn input(field: impl Into<Field>, message: impl Into<String>) -> Self {
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

    /// Returns the same error with `prefix: ` put in front of the field name, to nest context. The
    /// prefix is words or a front's [`Param`].
    #[must_use]
    pub fn in_context(self, prefix: impl Into<Field>) -> Self {
        match self {
            Error::InvalidValue {
                field,
                value,
                allowed,
            } => Error::InvalidValue {
                field: field.in_context(prefix),
                value,
                allowed,
            },
            Error::Input { field, message } => Error::Input {
                field: field.in_context(prefix),
                message,
            },
            other => other,
        }
    }

    /// Returns the message with each front's input named by `name` (a flag, an environment
    /// variable, a Python keyword) where the error names a [`Param`]. `Display` writes the params'
    /// neutral names instead.
    #[must_use]
    pub fn render(&self, name: &dyn Fn(Param) -> String) -> String {
        match self {
            Error::InvalidValue {
                field,
                value,
                allowed,
            } => format!("{} = {value} is invalid: {allowed}", field.render(name)),
            Error::Input { field, message } => format!("{}: {message}", field.render(name)),
            other => other.to_string(),
        }
    }

    /// Returns the front's input this error is about, if it names one.
    #[must_use]
    pub fn param(&self) -> Option<Param> {
        match self {
            Error::InvalidValue { field, .. } | Error::Input { field, .. } => field.first_param(),
            _ => None,
        }
    }
}

/// Names an input that each front gives under a name of its own: a flag or an environment
/// variable on the command line, a keyword in Python. The engine and the applications name it
/// by this neutral key. Each front renders it ([`Error::render`]), and `Display` writes its
/// neutral name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Param(&'static str);

impl Param {
    /// Returns the param of neutral name `name`.
    #[must_use]
    pub const fn new(name: &'static str) -> Self {
        Param(name)
    }

    /// Returns the neutral name.
    #[must_use]
    pub fn name(self) -> &'static str {
        self.0
    }
}

/// What an error is about: a field by its name (`sonar "rig.toml": range_max`), or a front's
/// input by its [`Param`], with words after it (`chunk_poses (the default)`). Either may sit
/// under the context it was met in (`--feature 2: feature azimuth`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field(Vec<Part>);

/// A piece of a [`Field`]: words, or a front's input.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Part {
    Text(String),
    Param(Param),
}

impl Field {
    /// Returns the field of `param`, followed by `text` (empty, or words such as
    /// ` (the default)`).
    #[must_use]
    pub fn param(param: Param, text: impl Into<String>) -> Self {
        let text = text.into();
        let mut parts = vec![Part::Param(param)];
        if !text.is_empty() {
            parts.push(Part::Text(text));
        }
        Field(parts)
    }

    /// Returns whether the field is the name `name` alone (no param, no context).
    #[must_use]
    pub fn is(&self, name: &str) -> bool {
        matches!(self.0.as_slice(), [Part::Text(t)] if t == name)
    }

    /// Returns the first front's input the field names, if any.
    #[must_use]
    pub fn first_param(&self) -> Option<Param> {
        self.0.iter().find_map(|p| match p {
            Part::Param(p) => Some(*p),
            Part::Text(_) => None,
        })
    }

    /// Returns the field with `name` rendering its params.
    #[must_use]
    pub fn render(&self, name: &dyn Fn(Param) -> String) -> String {
        self.0
            .iter()
            .map(|p| match p {
                Part::Text(t) => t.clone(),
                Part::Param(p) => name(*p),
            })
            .collect()
    }

    /// Returns the field under `prefix: `.
    #[must_use]
    pub fn in_context(self, prefix: impl Into<Field>) -> Self {
        let mut parts = prefix.into().0;
        parts.push(Part::Text(": ".into()));
        parts.extend(self.0);
        Field(parts)
    }
}

impl std::fmt::Display for Field {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render(&|p| p.name().to_string()))
    }
}

impl From<String> for Field {
    fn from(text: String) -> Self {
        Field(vec![Part::Text(text)])
    }
}

impl From<&str> for Field {
    fn from(text: &str) -> Self {
        Field::from(text.to_string())
    }
}

impl From<&String> for Field {
    fn from(text: &String) -> Self {
        Field::from(text.clone())
    }
}

impl From<Param> for Field {
    fn from(param: Param) -> Self {
        Field::param(param, "")
    }
}

/// Returns `text` quoted for an error message: whole up to
/// [`EXCERPT_CHARS`](crate::limits::EXCERPT_CHARS) characters, else its beginning, `…` and its
/// length in bytes. So a message never echoes a long piece of its input whole.
#[must_use]
pub fn excerpt(text: &str) -> String {
    let (head, mark) = cut(text, crate::limits::EXCERPT_CHARS);
    format!("{head:?}{mark}")
}

/// Returns `value` as an error shows it. A long number takes exponent form (`1e308`). Anything
/// else is whole up to [`MAX_VALUE_CHARS`](crate::limits::MAX_VALUE_CHARS) characters, else
/// cut there and marked with its length.
pub(crate) fn shortened(value: &str) -> String {
    // A huge or tiny number formats with all its digits (1e308 has 309). Say it as Rust reads it.
    if value.len() > 24
        && let Ok(v) = value.parse::<f64>()
        && v.is_finite()
    {
        return format!("{v:e}");
    }
    let (head, mark) = cut(value, crate::limits::MAX_VALUE_CHARS);
    format!("{head}{mark}")
}

/// Returns the first `chars` characters of `text`, and the mark `… (N bytes)` giving its whole
/// length when it has more (else an empty mark).
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

/// Returns `v` when it is finite, else [`Error::InvalidValue`] for the field `field()` names.
/// The name is built only for the error, since hot paths check every pose.
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

#[cfg(test)]
mod param_tests {
    use super::*;

    /// An error about a front's input keeps it as a value. `Display` writes its neutral name and
    /// each front its own, in the field and in any context around it.
    #[test]
    fn a_param_is_named_by_each_front_its_own_way() {
        const OUT: Param = Param::new("out");
        let flag = |p: Param| format!("--{}", p.name());
        let e = Error::invalid(Field::param(OUT, " (the default)"), 3, "must be >= 4").in_context("sweep");
        assert_eq!(e.param(), Some(OUT));
        assert_eq!(
            e.to_string(),
            "sweep: out (the default) = 3 is invalid: must be >= 4"
        );
        assert_eq!(
            e.render(&flag),
            "sweep: --out (the default) = 3 is invalid: must be >= 4"
        );
        let inner = Error::input("azimuth", "missing").in_context(OUT);
        assert_eq!(inner.render(&flag), "--out: azimuth: missing");
        assert_eq!(inner.to_string(), "out: azimuth: missing");
        assert!(Field::from("tx").is("tx") && !Field::from(OUT).is("out"));
        // Errors without a param read the same whichever front renders them.
        let plain = Error::invalid("range_max", 1, "must be > 2");
        assert_eq!(plain.render(&flag), plain.to_string());
        assert_eq!(plain.param(), None);
    }
}
