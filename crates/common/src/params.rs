//! Parameter files, loaded one way for every component: start from a preset (or the
//! defaults), lay the TOML file's tables over it key by key (unknown keys are errors), then
//! validate once; and the one error of every `validate`, [`ParamError`].

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Display;
use std::path::Path;

/// A parameter that holds an unusable value: which one, the value, and what it must be. Every
/// `validate` of the libraries returns it, or an error of its crate that wraps it and puts the
/// crate's words around it (`invalid updater parameter '…': …`). Nothing is reset silently: the
/// first bad parameter found is refused.
///
/// Its message is `{name} {requirement}, got {value}` (`, got {value}` left out when `value` is
/// empty), e.g. `rate_hz must be in [0.01, 1000], got 0`.
///
/// ```
/// use mapkeeper_common::ParamError;
/// let e = ParamError::new("sigma_m", -1.0, "must be finite and ≥ 0").within("noise");
/// assert_eq!(e.name, "noise.sigma_m");
/// assert_eq!(e.to_string(), "noise.sigma_m must be finite and ≥ 0, got -1");
/// ```
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct ParamError {
    /// The parameter as a parameter file writes it: the field's name, with the sections it
    /// lies in before it, dot-separated (`registration.inlier_m`, `noise.sigma_m`;
    /// [`ParamError::within`] adds a section). A rule that ties several fields is named by
    /// the field it is reported on, or by what the message calls them (`range limits`).
    pub name: String,
    /// The offending value as printed (`-1`, `NaN`, `inf`); several values are joined with
    /// `and`. Empty when the message gives none (the requirement may state it).
    pub value: String,
    /// What the value must satisfy, worded as the message puts it after the name: `must be
    /// finite and > 0`, `must lie in [0, 1]`, `must satisfy 0 ≤ range_min_m < range_max_m`.
    pub requirement: String,
}

impl ParamError {
    /// `name` holds `value` (printed with `Display`; `""` for none), which does not satisfy
    /// `requirement`.
    pub fn new(name: impl Into<String>, value: impl Display, requirement: impl Into<String>) -> Self {
        Self { name: name.into(), value: value.to_string(), requirement: requirement.into() }
    }

    /// `name` breaks `requirement`, a rule the requirement states whole: one between fields
    /// (`must not exceed max_error_m`), or one whose value the requirement already shows
    /// (`needs finite values, got Kidnap { … }`), with no single value to name apart.
    pub fn rule(name: impl Into<String>, requirement: impl Into<String>) -> Self {
        Self { name: name.into(), value: String::new(), requirement: requirement.into() }
    }

    /// The same error with `section.` before the name: for a field of a section (a nested
    /// struct), reported by the section's own `validate`.
    #[must_use]
    pub fn within(mut self, section: &str) -> Self {
        self.name = format!("{section}.{}", self.name);
        self
    }

    /// The message without the name: `{requirement}, got {value}` (or the requirement alone),
    /// for an error that names the parameter its own way (`invalid updater parameter
    /// 'buffer_size': must lie in 1..=32, got 40`).
    pub fn problem(&self) -> String {
        if self.value.is_empty() {
            self.requirement.clone()
        } else {
            format!("{}, got {}", self.requirement, self.value)
        }
    }
}

impl Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.name, self.problem())
    }
}

/// Why parameters were refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsError {
    /// Parameters given without a file (a preset, the defaults) are invalid.
    #[error("invalid parameters: {0}")]
    Invalid(String),
    /// A parameter file could not be read, parsed or validated.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong, and where.
        message: String,
    },
}

/// `base` overridden by the TOML file at `file` (if any), then checked by `validate`. Errors
/// name the file and, from the TOML parser, the line and the key.
pub fn load_params<T, E>(
    base: T,
    file: Option<&Path>,
    validate: impl FnOnce(&T) -> Result<(), E>,
) -> Result<T, ParamsError>
where
    T: Serialize + DeserializeOwned,
    E: Display,
{
    let Some(path) = file else {
        validate(&base).map_err(|e| ParamsError::Invalid(e.to_string()))?;
        return Ok(base);
    };
    let bad = |message: String| ParamsError::File { path: path.to_path_buf(), message };
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    params_from_toml_str(base, &text, validate).map_err(bad)
}

/// `base` overridden by the TOML text `text`, then checked by `validate`: the in-memory half of
/// [`load_params`] (which reads the file and puts its name before the error), so the fuzz
/// target `updater_params` does no file I/O. The error is the TOML parser's message (line and
/// column of a syntax error, the key of a wrong type or an unknown key) or the validator's.
pub fn params_from_toml_str<T, E>(base: T, text: &str, validate: impl FnOnce(&T) -> Result<(), E>) -> Result<T, String>
where
    T: Serialize + DeserializeOwned,
    E: Display,
{
    let over: toml::Value = toml::from_str(text).map_err(|e| e.to_string().trim().to_owned())?;
    let mut value = toml::Value::try_from(&base).map_err(|e| format!("cannot serialise the preset: {e}"))?;
    merge(&mut value, over);
    let params: T = value.try_into().map_err(|e: toml::de::Error| e.to_string().trim().to_owned())?;
    validate(&params).map_err(|e| e.to_string())?;
    Ok(params)
}

/// Lays `over` onto `base`, table by table; any other value replaces the base's.
fn merge(base: &mut toml::Value, over: toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct P {
        a: f64,
        inner: Inner,
    }
    #[derive(Debug, PartialEq, Serialize, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        b: u32,
        c: u32,
    }
    impl Default for P {
        fn default() -> Self {
            Self { a: 1.0, inner: Inner::default() }
        }
    }
    impl Default for Inner {
        fn default() -> Self {
            Self { b: 2, c: 3 }
        }
    }
    fn check(p: &P) -> Result<(), ParamError> {
        if p.a >= 0.0 { Ok(()) } else { Err(ParamError::new("a", p.a, "must be ≥ 0")) }
    }

    fn file(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("mapkeeper-common-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn a_file_overrides_one_key_of_a_table_and_keeps_the_preset_elsewhere() {
        let base = P { a: 5.0, inner: Inner { b: 7, c: 9 } };
        let p = load_params(base, Some(&file("one.toml", "[inner]\nc = 4\n")), check).unwrap();
        assert_eq!(p, P { a: 5.0, inner: Inner { b: 7, c: 4 } });
    }

    #[test]
    fn unknown_keys_bad_syntax_and_invalid_values_name_the_file_and_the_key() {
        for (name, text, needle) in [
            ("unknown.toml", "d = 1\n", "d"),
            ("syntax.toml", "a = \n", "line 1"),
            ("invalid.toml", "a = -1.0\n", "a must"),
        ] {
            let e = load_params(P::default(), Some(&file(name, text)), check).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(needle), "{e}");
        }
        let e = load_params(P::default(), Some(Path::new("/nonexistent/x.toml")), check).unwrap_err().to_string();
        assert!(e.contains("x.toml") && e.contains("cannot read"), "{e}");
    }

    #[test]
    fn a_param_error_names_the_parameter_the_value_and_the_requirement() {
        let e = ParamError::new("rate_hz", 0.0, "must be in [0.01, 1000]");
        assert_eq!(e.to_string(), "rate_hz must be in [0.01, 1000], got 0");
        assert_eq!(
            (e.name.as_str(), e.value.as_str(), e.requirement.as_str()),
            ("rate_hz", "0", "must be in [0.01, 1000]")
        );
        // Values are printed as `Display` prints them: no exponent, NaN and inf spelt out.
        assert_eq!(ParamError::new("x", 1e-11, "must be > 0").value, "0.00000000001");
        assert_eq!(ParamError::new("x", f64::NAN, "must be finite").to_string(), "x must be finite, got NaN");
        // No value: the requirement says it all.
        let e = ParamError::new("beams", "", "must span at most a full turn");
        assert_eq!(e.to_string(), "beams must span at most a full turn");
        assert_eq!(e.problem(), "must span at most a full turn");
        assert_eq!(ParamError::new("x", 2, "must be < 1").problem(), "must be < 1, got 2");
        // Sections go before the name, innermost last.
        let e = ParamError::new("sigma_m", -1, "must be finite and ≥ 0").within("noise").within("lidar");
        assert_eq!(e.to_string(), "lidar.noise.sigma_m must be finite and ≥ 0, got -1");
        // It is an error (a `Box<dyn Error>`, a `?` into anyhow).
        let boxed: Box<dyn std::error::Error> = Box::new(e.clone());
        assert_eq!(boxed.to_string(), e.to_string());
        // load_params puts its message after the file's name.
        let f = file("bad.toml", "a = -2.0\n");
        let m = load_params(P::default(), Some(&f), check).unwrap_err().to_string();
        assert!(m.ends_with("bad.toml: a must be ≥ 0, got -2"), "{m}");
    }
}
