//! Reads the keys of TOML configuration files: a sweep file and its `[summary]`, an advise
//! file and its `[features]`. Each error names the file and key, then the value and what is
//! allowed: `sweep file "s.toml": rotation.roll.step = 0 is invalid: must be > 0`.

use crate::error::{Error, Result};
use sonarproj::limits::MAX_AXIS_VALUES;

/// A configuration file as its errors name it: its kind (`sweep file`, `advise file`) and path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ConfigFile<'a> {
    kind: &'static str,
    path: &'a str,
}

impl<'a> ConfigFile<'a> {
    /// Returns the sweep file at `path` (as messages show it).
    pub(crate) fn sweep(path: &'a str) -> Self {
        ConfigFile {
            kind: "sweep file",
            path,
        }
    }

    /// Returns the advise file at `path` (as messages show it).
    pub(crate) fn advise(path: &'a str) -> Self {
        ConfigFile {
            kind: "advise file",
            path,
        }
    }

    /// Returns the path as messages show it.
    pub(crate) fn path(self) -> &'a str {
        self.path
    }

    /// Returns the field an error about `key` names: the file, then the key.
    pub(crate) fn field(self, key: &str) -> String {
        format!("{} {:?}: {key}", self.kind, self.path)
    }

    /// Returns the error of `key` holding `value`, with what is `allowed`.
    pub(crate) fn error(self, key: &str, value: impl std::fmt::Display, allowed: impl Into<String>) -> Error {
        Error::invalid(self.field(key), value, allowed)
    }

    /// Returns the error of the missing `key`, which `needed` explains.
    pub(crate) fn missing(self, key: &str, needed: &str) -> Error {
        Error::input(self.field(key), format!("missing; {needed}"))
    }

    /// Returns an error naming the first key of `table` (under `section`, such as `search.`)
    /// that is not in `allowed`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming the key.
    pub(crate) fn only(self, section: &str, table: &toml::Table, allowed: &[&str]) -> Result<()> {
        match table.keys().find(|k| !allowed.contains(&k.as_str())) {
            Some(k) => Err(self.error(
                &format!("{section}{k}"),
                table[k].clone(),
                format!("unknown key (allowed: {})", allowed.join(", ")),
            )),
            None => Ok(()),
        }
    }

    /// Returns the string of key `key` of `table` (`None` when left out).
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] when it is not a string.
    pub(crate) fn string<'t>(self, table: &'t toml::Table, key: &str) -> Result<Option<&'t str>> {
        match table.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s)),
            Some(other) => Err(self.error(key, other, "must be a string")),
        }
    }

    /// Returns the table of key `key` of `table` (`None` when left out).
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] when it is not a table.
    pub(crate) fn table<'t>(self, table: &'t toml::Table, key: &str) -> Result<Option<&'t toml::Table>> {
        match table.get(key) {
            None => Ok(None),
            Some(toml::Value::Table(t)) => Ok(Some(t)),
            Some(other) => Err(self.error(key, other, "must be a table")),
        }
    }

    /// Returns the number at `key` in `table`, or `None` when left out. Messages call it `name`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `name` unless it is one finite number.
    pub(crate) fn number(self, table: &toml::Table, name: &str, key: &str) -> Result<Option<f64>> {
        let Some(v) = table.get(key) else { return Ok(None) };
        if !(v.is_integer() || v.is_float() || v.is_array() || v.is_table()) {
            return Err(self.error(name, v, "must be one number"));
        }
        match self.values(name, v)?.as_slice() {
            [x] => Ok(Some(*x)),
            _ => Err(self.error(name, v, "must be one number")),
        }
    }

    /// Returns `v` of key `name` when it is in `[lo, hi]`. `unit` follows the bounds in messages.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `name` otherwise.
    pub(crate) fn in_range(self, name: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64> {
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(self.error(name, v, format!("must be in [{lo}, {hi}]{unit}")))
        }
    }

    /// Returns the whole number of key `name` within `[lo, hi]`, or `None` when left out. The last
    /// part of `name` is its key in `table`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `name` otherwise.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "checked range"
    )]
    pub(crate) fn whole(self, table: &toml::Table, name: &str, lo: f64, hi: f64) -> Result<Option<u64>> {
        let key = name.rsplit('.').next().unwrap_or(name);
        match self.number(table, name, key)? {
            None => Ok(None),
            Some(v) if v.fract() == 0.0 && (lo..=hi).contains(&v) => Ok(Some(v as u64)),
            Some(v) => Err(self.error(name, v, format!("must be a whole number in [{lo}, {hi}]"))),
        }
    }

    /// Returns the values of key `key` given as `v`: a number, a list of numbers, or
    /// `{ start, stop, step }` for start, start + step, … up to stop. At most [`MAX_AXIS_VALUES`].
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming the wrong key, element or part of the range.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "a range's count is checked against MAX_AXIS_VALUES before it is a count"
    )]
    pub(crate) fn values(self, key: &str, v: &toml::Value) -> Result<Vec<f64>> {
        let shape = "must be a number, a list of numbers or { start, stop, step }";
        match v {
            toml::Value::Integer(_) | toml::Value::Float(_) => Ok(vec![self.finite(v, key)?]),
            toml::Value::Array(a) if !a.is_empty() => a
                .iter()
                .enumerate()
                .map(|(i, x)| self.finite(x, &format!("{key}[{i}]")))
                .collect(),
            toml::Value::Array(_) => Err(self.error(key, "[]", "must list at least one value")),
            toml::Value::Table(t) => {
                self.only(&format!("{key}."), t, &["start", "stop", "step"])?;
                let get = |k: &str| -> Result<f64> {
                    let full = format!("{key}.{k}");
                    match t.get(k) {
                        Some(x) => self.finite(x, &full),
                        None => Err(self.missing(&full, "required with start, stop, step")),
                    }
                };
                let (start, stop, step) = (get("start")?, get("stop")?, get("step")?);
                if step <= 0.0 {
                    return Err(self.error(&format!("{key}.step"), step, "must be > 0"));
                }
                if stop < start {
                    return Err(self.error(
                        &format!("{key}.stop"),
                        stop,
                        format!("must be >= start ({start})"),
                    ));
                }
                let n = ((stop - start) / step + 1e-9).floor();
                if n >= MAX_AXIS_VALUES as f64 {
                    return Err(self.error(
                        &format!("{key}.step"),
                        step,
                        format!(
                            "gives {} values from {start} to {stop}; at most {MAX_AXIS_VALUES} per axis",
                            n + 1.0
                        ),
                    ));
                }
                Ok((0..=n as u64).map(|i| start + i as f64 * step).collect())
            }
            other => Err(self.error(key, other, shape)),
        }
    }

    /// Returns the finite number `v` of key `key`.
    #[expect(clippy::cast_precision_loss, reason = "TOML integers taken as numbers")]
    fn finite(self, v: &toml::Value, key: &str) -> Result<f64> {
        let x = match v {
            toml::Value::Integer(i) => *i as f64,
            toml::Value::Float(f) => *f,
            other => return Err(self.error(key, other, "must be a number")),
        };
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.error(key, x, "must be a finite number"))
        }
    }
}

/// Returns the numbers of TOML array `v`, or `None` unless every element is one. A stray
/// string is refused, not skipped.
pub(crate) fn numbers(v: &toml::Value) -> Option<Vec<f64>> {
    #[expect(clippy::cast_precision_loss, reason = "TOML integers taken as numbers")]
    let number = |x: &toml::Value| x.as_float().or(x.as_integer().map(|i| i as f64));
    v.as_array()?.iter().map(number).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    /// Every error names the file's kind and path and the key, then the value and the rule.
    #[test]
    fn errors_name_the_file_and_the_key() {
        let f = ConfigFile::sweep("s.toml");
        let t = table("a = 1\nb = \"x\"\nc = { start = 0, stop = 1, step = 0 }\nd = [1, \"2\"]\n");
        let message = |r: Result<_>| r.map(|_: Option<f64>| ()).unwrap_err().to_string();
        assert_eq!(
            message(f.only("", &t, &["a"]).map(|()| None)),
            "sweep file \"s.toml\": b = \"x\" is invalid: unknown key (allowed: a)"
        );
        assert!(message(f.number(&t, "b", "b")).starts_with("sweep file \"s.toml\": b = \"x\""));
        let step = f.values("c", &t["c"]).unwrap_err().to_string();
        assert_eq!(step, "sweep file \"s.toml\": c.step = 0 is invalid: must be > 0");
        let element = f.values("d", &t["d"]).unwrap_err().to_string();
        assert!(
            element.contains("d[1]") && element.contains("must be a number"),
            "{element}"
        );
        let advise = ConfigFile::advise("a.toml")
            .whole(&t, "a", 2.0, 3.0)
            .unwrap_err()
            .to_string();
        assert_eq!(
            advise,
            "advise file \"a.toml\": a = 1 is invalid: must be a whole number in [2, 3]"
        );
        assert_eq!(
            f.missing("e", "required").to_string(),
            f.field("e") + ": missing; required"
        );
    }

    /// A range runs start, start + step, … up to its stop, included when it falls on a step
    /// within rounding. A number or a list is itself.
    #[test]
    fn values_are_numbers_lists_and_ranges() {
        let f = ConfigFile::sweep("s.toml");
        let t = table("a = 2\nb = [1, 2.5]\nc = { start = 0, stop = 0.3, step = 0.1 }\n");
        assert_eq!(f.values("a", &t["a"]).unwrap(), [2.0]);
        assert_eq!(f.values("b", &t["b"]).unwrap(), [1.0, 2.5]);
        let c = f.values("c", &t["c"]).unwrap();
        assert_eq!(c.len(), 4);
        assert!((c[3] - 0.3).abs() < 1e-12, "{c:?}");
    }
}
