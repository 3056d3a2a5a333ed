//! Reading [`UpdaterParams`] with the names of files written before the `removal` section:
//! `removal_hit_clearance_m`, `removal_min_incidence_rad`, `removal_max_offset_cells` and
//! `removal_shadow` at the top level. A parameter file that sets them, or a record
//! (`runs.json`, `summary.json`, a checkpoint) that holds them, still loads, with the same
//! values; written, the parameters always hold the section. A flat name, when present,
//! overrides the section's field (a parameter file is laid over a preset whose section is
//! already there). Every other key goes to the derived deserialiser unchanged, so unknown keys,
//! wrong types and their messages (with the TOML key or the JSON line and column) are as they
//! were.

use super::RemovalParams;
use super::{UpdaterParams, inf_as_text};
use serde::de::value::MapAccessDeserializer;
use serde::de::{DeserializeSeed, Deserializer, Error, IntoDeserializer, MapAccess, Visitor};
use std::fmt;

/// The flat names, in the order of the section's fields.
const FLAT_NAMES: [&str; 4] =
    ["removal_hit_clearance_m", "removal_min_incidence_rad", "removal_max_offset_cells", "removal_shadow"];

/// The values given under the flat names.
#[derive(Default)]
struct Flat {
    hit_clearance_m: Option<f64>,
    min_incidence_rad: Option<f64>,
    max_offset_cells: Option<f64>,
    shadow: Option<bool>,
}

impl Flat {
    fn apply(self, removal: &mut RemovalParams) {
        removal.hit_clearance_m = self.hit_clearance_m.unwrap_or(removal.hit_clearance_m);
        removal.min_incidence_rad = self.min_incidence_rad.unwrap_or(removal.min_incidence_rad);
        removal.max_offset_cells = self.max_offset_cells.unwrap_or(removal.max_offset_cells);
        removal.shadow = self.shadow.unwrap_or(removal.shadow);
    }
}

/// A value read with [`inf_as_text`] (`"inf"` for infinity), as `removal_max_offset_cells` was.
struct InfAsText;

impl<'de> DeserializeSeed<'de> for InfAsText {
    type Value = f64;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<f64, D::Error> {
        inf_as_text::deserialize(d)
    }
}

/// The map of an `UpdaterParams` without its flat names, which it keeps in `flat`.
struct WithoutFlat<'a, A> {
    map: A,
    flat: &'a mut Flat,
}

/// `slot` set to `value`, or the error of a name given twice.
fn set<T, E: Error>(slot: &mut Option<T>, value: T, name: &'static str) -> Result<(), E> {
    if slot.replace(value).is_some() {
        return Err(E::duplicate_field(name));
    }
    Ok(())
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for WithoutFlat<'_, A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>, A::Error> {
        loop {
            let Some(key) = self.map.next_key::<String>()? else { return Ok(None) };
            let flat = &mut *self.flat;
            match key.as_str() {
                "removal_hit_clearance_m" => {
                    set(&mut flat.hit_clearance_m, self.map.next_value()?, FLAT_NAMES[0])?;
                }
                "removal_min_incidence_rad" => {
                    set(&mut flat.min_incidence_rad, self.map.next_value()?, FLAT_NAMES[1])?;
                }
                "removal_max_offset_cells" => {
                    set(&mut flat.max_offset_cells, self.map.next_value_seed(InfAsText)?, FLAT_NAMES[2])?;
                }
                "removal_shadow" => set(&mut flat.shadow, self.map.next_value()?, FLAT_NAMES[3])?,
                _ => return seed.deserialize(key.into_deserializer()).map(Some),
            }
        }
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

struct ParamsVisitor;

impl<'de> Visitor<'de> for ParamsVisitor {
    type Value = UpdaterParams;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("struct UpdaterParams")
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<UpdaterParams, A::Error> {
        let mut flat = Flat::default();
        // The derived deserialiser (`#[serde(remote = "Self")]`), fed the other keys.
        let mut params = UpdaterParams::deserialize(MapAccessDeserializer::new(WithoutFlat { map, flat: &mut flat }))?;
        flat.apply(&mut params.removal);
        Ok(params)
    }
}

/// [`UpdaterParams`] from a map that may hold the flat names.
pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<UpdaterParams, D::Error> {
    d.deserialize_map(ParamsVisitor)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file of the `mapkeeper` preset's removal gates written before the section: read
    /// into the section, over any preset.
    #[test]
    fn the_flat_names_of_old_files_and_records_still_load() {
        let text = "removal_hit_clearance_m = 0.2\nremoval_min_incidence_rad = 0.17453292519943295\n\
                    removal_max_offset_cells = \"inf\"\nremoval_shadow = true\n";
        for name in crate::PRESET_NAMES {
            let base = UpdaterParams::preset(name).unwrap();
            let p = mapkeeper_common::params_from_toml_str(base.clone(), text, UpdaterParams::validate).unwrap();
            assert_eq!(p, UpdaterParams { removal: RemovalParams::mapkeeper(), ..base }, "{name}");
        }
        // A record (JSON): the flat names anywhere among the others, "inf" as text.
        let json = r#"{"buffer_size": 12, "removal_max_offset_cells": "inf", "removal_shadow": true,
            "removal_hit_clearance_m": 0.125}"#;
        let p: UpdaterParams = serde_json::from_str(json).unwrap();
        let want = RemovalParams { hit_clearance_m: 0.125, shadow: true, ..RemovalParams::default() };
        assert_eq!((p.buffer_size, p.removal), (12, want));
        // The section is what is written.
        let written = serde_json::to_value(&p).unwrap();
        assert_eq!(written["removal"]["hit_clearance_m"], 0.125);
        assert!(FLAT_NAMES.iter().all(|n| written.get(n).is_none()), "{written}");
    }

    #[test]
    fn a_flat_name_overrides_the_section_and_is_checked_like_it() {
        let p: UpdaterParams = serde_json::from_str(
            r#"{"removal": {"hit_clearance_m": 0.3, "shadow": true}, "removal_hit_clearance_m": 0.1}"#,
        )
        .unwrap();
        assert_eq!((p.removal.hit_clearance_m, p.removal.shadow), (0.1, true));
        let e = mapkeeper_common::params_from_toml_str(
            UpdaterParams::paper(),
            "removal_min_incidence_rad = 2.0\n",
            UpdaterParams::validate,
        )
        .unwrap_err();
        assert_eq!(e, "invalid updater parameter 'removal.min_incidence_rad': must be within 0..=pi/2, got 2");
    }

    #[test]
    fn other_keys_are_refused_as_before() {
        let e = serde_json::from_str::<UpdaterParams>(r#"{"buffer_size": 12, "bufer_size": 3}"#).unwrap_err();
        assert!(e.to_string().starts_with("unknown field `bufer_size`") && e.line() == 1, "{e}");
        let e = serde_json::from_str::<UpdaterParams>(r#"{"removal_shadow": 3}"#).unwrap_err();
        assert!(e.to_string().contains("expected a boolean"), "{e}");
        let e =
            serde_json::from_str::<UpdaterParams>(r#"{"removal_shadow": true, "removal_shadow": false}"#).unwrap_err();
        assert!(e.to_string().starts_with("duplicate field `removal_shadow`"), "{e}");
        let e = serde_json::from_str::<UpdaterParams>(r#"{"removal": {"hit_clearance": 0.1}}"#).unwrap_err();
        assert!(e.to_string().starts_with("unknown field `hit_clearance`"), "{e}");
        // TOML names the key of a wrong type.
        let e = mapkeeper_common::params_from_toml_str(
            UpdaterParams::paper(),
            "removal_shadow = 3\n",
            UpdaterParams::validate,
        )
        .unwrap_err();
        assert!(e.contains("removal_shadow"), "{e}");
        assert!(serde_json::from_str::<UpdaterParams>("[]").is_err());
    }
}
