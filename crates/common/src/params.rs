//! Parameter files, loaded one way for every component: start from a preset (or the
//! defaults), lay the TOML file's tables over it key by key (unknown keys are errors), then
//! validate once.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Display;
use std::path::Path;

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
    fn check(p: &P) -> Result<(), String> {
        if p.a >= 0.0 { Ok(()) } else { Err(format!("a must be ≥ 0, got {}", p.a)) }
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
}
