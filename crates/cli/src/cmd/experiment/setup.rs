//! What every experiment of the recovery family sets up the same way: its parameter file
//! (`[recovery]` and its own table, [`ExperimentFile`]; its world W_1 is `cmd::site::site_world`).

use super::Common;
use anyhow::Context;
use mapkeeper_scenario::RecoveryParams;
use mapkeeper_scenario::experiments::ExperimentError;
use serde::de::{self, DeserializeOwned, MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;
use std::marker::PhantomData;

/// An experiment's own table in its parameter file.
pub(super) trait ExperimentTable: Default + Serialize + DeserializeOwned {
    /// The table's name (`[check_detection]`, …).
    const TABLE: &'static str;
    /// The file's keys, `recovery` and [`ExperimentTable::TABLE`], as an unknown key's error
    /// lists them.
    const KEYS: &'static [&'static str];
    /// The `--quick` setting.
    fn quick() -> Self;
    /// Checks the table.
    fn check(&self) -> Result<(), ExperimentError>;
}

/// The parameter file of an experiment of the recovery family: `[recovery]` and the
/// experiment's own table `P` (each optional: what is missing keeps its default; any other key is
/// refused, naming the keys there are).
#[derive(Clone, Debug, Default)]
pub(super) struct ExperimentFile<P> {
    /// The `[recovery]` table: worlds, tour, loop, maps.
    pub recovery: RecoveryParams,
    /// The experiment's own table.
    pub own: P,
}

impl<P: ExperimentTable> ExperimentFile<P> {
    /// Both tables checked.
    fn check(&self) -> Result<(), ExperimentError> {
        self.recovery.validate()?;
        self.own.check()
    }
}

impl<P: ExperimentTable> Serialize for ExperimentFile<P> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("recovery", &self.recovery)?;
        m.serialize_entry(P::TABLE, &self.own)?;
        m.end()
    }
}

impl<'de, P: ExperimentTable> Deserialize<'de> for ExperimentFile<P> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Tables<P>(PhantomData<P>);
        impl<'de, P: ExperimentTable> Visitor<'de> for Tables<P> {
            type Value = ExperimentFile<P>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "tables [recovery] and [{}]", P::TABLE)
            }
            fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Self::Value, A::Error> {
                let mut file = ExperimentFile::<P>::default();
                while let Some(key) = a.next_key::<String>()? {
                    match key.as_str() {
                        "recovery" => file.recovery = a.next_value()?,
                        k if k == P::TABLE => file.own = a.next_value()?,
                        k => return Err(de::Error::unknown_field(k, P::KEYS)),
                    }
                }
                Ok(file)
            }
        }
        d.deserialize_map(Tables(PhantomData))
    }
}

/// An experiment's parameters, one way for all: the defaults with `--localiser`, then the
/// `--quick` setting, then the `--params` file laid over them, validated.
pub(super) fn load_file<P: ExperimentTable>(c: &Common, quick: bool) -> anyhow::Result<ExperimentFile<P>> {
    let mut base = ExperimentFile::<P>::default();
    base.recovery.runner.set_localiser(&c.localiser).context("--localiser")?;
    if quick {
        base.own = P::quick();
    }
    crate::cmd::load_params(base, c.params.as_deref(), ExperimentFile::check)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_scenario::experiments::check_detection::CheckDetectionParams;

    #[test]
    fn the_file_round_trips_and_refuses_an_unknown_table_naming_the_keys() {
        let mut file = ExperimentFile::<CheckDetectionParams>::default();
        file.own.trials = 7;
        let text = toml::to_string(&file).expect("serialise");
        assert!(text.contains("[check_detection]") && text.contains("[recovery"), "{text}");
        let back: ExperimentFile<CheckDetectionParams> = toml::from_str(&text).expect("read back");
        assert_eq!(back.own.trials, 7);
        let e = toml::from_str::<ExperimentFile<CheckDetectionParams>>("[check_detections]\ntrials = 3\n")
            .expect_err("unknown table");
        let msg = e.to_string();
        assert!(msg.contains("unknown field `check_detections`, expected `recovery` or `check_detection`"), "{msg}");
        let partial: ExperimentFile<CheckDetectionParams> =
            toml::from_str("[check_detection]\ntrials = 3\n").expect("recovery defaults");
        assert_eq!(partial.own.trials, 3);
    }
}
