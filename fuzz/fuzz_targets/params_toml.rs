//! Parameter files (serde + `validate()`) of the grid (MapperParams, MetricParams), the
//! simulator (SimParams) and the localiser (FilterParams), and `RecoveryParams` as
//! `recover --params` loads it (overlaid on the defaults): the same text is tried as each.
//! Never panics; a syntax error names the line, a bad value names the parameter.
#![no_main]
use libfuzzer_sys::fuzz_target;

fn check<T: serde::de::DeserializeOwned, E: std::fmt::Display>(text: &str, validate: impl Fn(&T) -> Result<(), E>) {
    match toml::from_str::<T>(text) {
        Ok(p) => {
            if let Err(e) = validate(&p) {
                assert!(!e.to_string().is_empty());
            }
        }
        Err(e) => {
            // A syntax or type error: the toml crate names the line and column when it has a span.
            let m = e.to_string();
            assert!(e.span().is_none() || m.contains("line "), "{m}");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    check(text, mapkeeper_grid::mapper::MapperParams::validate);
    check(text, mapkeeper_grid::metrics::MetricParams::validate);
    check(text, mapkeeper_sim::SimParams::validate);
    check(text, mapkeeper_localiser::FilterParams::validate);
    let base = mapkeeper_scenario::RecoveryParams::default();
    match mapkeeper_common::params_from_toml_str(base, text, mapkeeper_scenario::RecoveryParams::validate) {
        // What validation accepts, the kidnap suite's draws must take.
        Ok(p) => {
            for trial in 0..4 {
                let _ = mapkeeper_scenario::experiments::recovery::draw_trial(&p, 7, trial);
            }
        }
        // The CLI joins a TOML error's lines; a syntax error names its line.
        Err(m) => assert!(!m.is_empty() && (!m.starts_with("TOML parse error") || m.contains("line ")), "{m}"),
    }
});
