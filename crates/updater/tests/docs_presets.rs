//! The preset table of `docs/updater.md` ("Parameters") against the presets in the code: every
//! cell that states a value (a number, with `°` or `°/s` for angles and `∞` for off, a boolean,
//! an enum name, or `on` / `off` for a section's `enabled`) must be the preset's value, to the
//! precision the cell is written with. `same` and `as paper` mean the `paper` column's cell.
//! Cells that only describe (`see params.rs`, `n_e = ceil(4°/Δθ)`) are listed as not checked,
//! and most cells must be checked: a table that drifts from the code fails here.
#![allow(clippy::unwrap_used)]

use mapkeeper_updater::UpdaterParams;
use serde_json::Value;
use std::path::PathBuf;

const PRESETS: [&str; 4] = ["paper", "paper-strict", "authors", "mapkeeper"];

/// The table's rows: (field names of the first column, the four preset cells).
fn table() -> Vec<(Vec<String>, Vec<String>)> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/updater.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text.find("| field | meaning | `paper`").expect("the preset table in docs/updater.md");
    let mut rows = Vec::new();
    for line in text[start..].lines().skip(2).take_while(|l| l.starts_with('|')) {
        let cells: Vec<String> = line.trim_matches('|').split(" | ").map(|c| c.trim().to_string()).collect();
        assert_eq!(cells.len(), 6, "a row of the preset table without six cells: {line}");
        let fields = cells[0].split(", ").map(|f| f.trim_matches('`').to_string()).collect();
        rows.push((fields, cells[2..].to_vec()));
    }
    rows
}

/// A cell's tokens: parenthesised remarks and quotes dropped, split at commas.
fn tokens(cell: &str) -> Vec<String> {
    let mut out = String::new();
    let mut depth = 0;
    for ch in cell.chars() {
        match ch {
            '(' => depth += 1,
            ')' => depth -= 1,
            '"' | '`' => {}
            _ if depth == 0 => out.push(ch),
            _ => {}
        }
    }
    out.split(',').map(|t| t.trim().to_string()).filter(|t| !t.is_empty()).collect()
}

/// Whether `token` states `value`: `Some(true/false)`, or `None` when the token states no value
/// this test can read.
fn states(token: &str, value: &Value) -> Option<bool> {
    let t = token.trim();
    match value {
        Value::Bool(b) => match t {
            "true" | "on" => Some(*b),
            "false" | "off" => Some(!*b),
            _ => None,
        },
        // Infinite reals are written as the string "inf" (JSON has no infinity).
        Value::String(s) if s == "inf" => (t == "∞" || t == "off").then_some(true).or(Some(false)),
        Value::String(s) => {
            let norm = |x: &str| x.to_lowercase().replace('-', "_");
            t.chars().all(|c| c.is_alphanumeric() || c == '-' || c == '_').then(|| norm(t) == norm(s))
        }
        Value::Null if t == "∞" || t == "off" => Some(true),
        Value::Number(n) => {
            let v = n.as_f64()?;
            if t == "∞" || t == "off" {
                return Some(v.is_infinite());
            }
            let (num, degrees) = match t.strip_suffix("°/s").or_else(|| t.strip_suffix('°')) {
                Some(d) => (d, true),
                None => (t, false),
            };
            let x: f64 = num.parse().ok()?;
            let decimals = num.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
            let tol = 0.5001 * 10f64.powi(-decimals);
            let want = if degrees { v.to_degrees() } else { v };
            Some((x - want).abs() <= tol)
        }
        _ => None,
    }
}

/// The value of a field of a preset (`a.b` for a section's field). A section (`x.*`) is read as
/// its `enabled`: `false` when the section is not written (off with default values), `None`
/// when it has no `enabled` (the row then only describes); a field of a section not written is
/// null (the table says `off`).
fn value(preset: &Value, field: &str) -> Result<Option<Value>, String> {
    if let Some(section) = field.strip_suffix(".*") {
        return Ok(match preset.get(section) {
            None => Some(Value::Bool(false)),
            Some(s) => s.get("enabled").cloned(),
        });
    }
    // A field of a section this preset does not write (off with its defaults) reads as off,
    // if some preset writes the section and has the field.
    if let Some((section, _)) = field.split_once('.')
        && preset.get(section).is_none()
    {
        let full = serde_json::to_value(UpdaterParams::mapkeeper()).unwrap();
        full.pointer(&format!("/{}", field.replace('.', "/"))).ok_or_else(|| format!("`{field}`: no such field"))?;
        return Ok(Some(Value::Null));
    }
    let mut v = preset;
    for part in field.split('.') {
        v = v.get(part).ok_or_else(|| format!("`{field}`: no such field"))?;
    }
    Ok(Some(v.clone()))
}

#[test]
fn the_preset_table_states_the_presets_values() {
    let presets: Vec<Value> =
        PRESETS.iter().map(|p| serde_json::to_value(UpdaterParams::preset(p).unwrap()).unwrap()).collect();
    let (mut checked, mut unchecked, mut wrong) = (0, Vec::new(), Vec::new());
    for (fields, cells) in table() {
        for (k, preset) in presets.iter().enumerate() {
            let cell = if matches!(cells[k].as_str(), "same" | "as paper") { &cells[0] } else { &cells[k] };
            let toks = tokens(cell);
            let values = match fields.iter().map(|f| value(preset, f)).collect::<Result<Option<Vec<Value>>, _>>() {
                Ok(Some(values)) => values,
                Ok(None) => {
                    unchecked.push(format!("{} {fields:?}: {cell}", PRESETS[k]));
                    continue;
                }
                Err(e) => {
                    wrong.push(format!("{} {e}", PRESETS[k]));
                    continue;
                }
            };
            // A section's row may add words after its on/off ("on, `on_alarm`"): its first token.
            let toks =
                if fields.len() == 1 && fields[0].ends_with(".*") { toks.into_iter().take(1).collect() } else { toks };
            if toks.len() != values.len() {
                unchecked.push(format!("{} {fields:?}: {cell}", PRESETS[k]));
                continue;
            }
            for ((t, v), f) in toks.iter().zip(&values).zip(&fields) {
                match states(t, v) {
                    Some(true) => checked += 1,
                    Some(false) => wrong.push(format!("{} `{f}`: the table says {t}, the code has {v}", PRESETS[k])),
                    None => unchecked.push(format!("{} `{f}`: {t} (code: {v})", PRESETS[k])),
                }
            }
        }
    }
    assert!(wrong.is_empty(), "docs/updater.md's preset table differs from the code:\n{}", wrong.join("\n"));
    println!("checked {checked} values; not read: {unchecked:#?}");
    assert!(checked >= 4 * unchecked.len() && checked > 100, "only {checked} values checked; not read: {unchecked:#?}");
}
