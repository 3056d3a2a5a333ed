//! The units of a validation's intervals: over the seeds with two or more, over batches of the
//! one seed's consecutive worlds with one (the default run), none with one seed of few worlds;
//! in `summary.json`, the report, the claims, the presets' comparison and the CI gate alike.
//! Built from the committed record of `tests/data/validation_run` (one seed, W_2), its row
//! copied into chains of worlds with known values.

use mapkeeper_scenario::experiments::validation::comparison::Comparison;
use mapkeeper_scenario::experiments::validation::markdown::report_md;
use mapkeeper_scenario::experiments::validation::merge::check_summary_json;
use mapkeeper_scenario::experiments::validation::{SeedRecord, ValidationRecord};
use mapkeeper_scenario::stats::{IntervalUnits, batch_means_half_width, mean, paired_diff};

fn record() -> ValidationRecord {
    let text = include_str!("../../../tests/data/validation_run/runs.json");
    serde_json::from_str(text).expect("the committed runs.json loads")
}

/// Seed `seed` with worlds 2 … `rows` + 1, world i's M_i/G_i CC (and the chain's error) made
/// from `gain(i)`; M_1/G_i as in the committed row.
fn seed(base: &SeedRecord, seed: u64, rows: usize, gain: impl Fn(usize) -> f64) -> SeedRecord {
    let mut s = base.clone();
    s.seed = seed;
    s.rows = (0..rows)
        .map(|k| {
            let mut w = base.rows[0].clone();
            w.seed = seed;
            w.world = k + 2;
            w.updated_map.cc = w.static_map.cc + gain(k + 2);
            w.loc_updated.mean_error_m = w.loc_static.mean_error_m + 0.001 * gain(k + 2);
            w
        })
        .collect();
    s
}

/// A gain that wanders with the worlds (positive throughout).
fn wandering(i: usize) -> f64 {
    5.0 + ((i * 7919) % 13) as f64 / 4.0
}

fn with_seeds(seeds: Vec<SeedRecord>) -> ValidationRecord {
    let mut r = record();
    r.params.worlds = seeds[0].rows.len() + 1;
    r.seeds = seeds;
    r
}

#[test]
fn one_seed_is_summarised_over_batches_of_its_worlds() {
    let base = record().seeds.remove(0);
    let r = with_seeds(vec![seed(&base, 11, 99, wandering)]);
    let s = r.summary();
    assert_eq!(s.interval_units, IntervalUnits::WorldBatches);
    let gains: Vec<f64> = r.seeds[0].rows.iter().map(|w| w.updated_map.cc - w.static_map.cc).collect();
    let half = batch_means_half_width(&gains).expect("99 worlds make 10 batches");
    assert!(half > 0.0);
    let cc = s.map_quality.cc;
    assert_eq!(cc.diff_mean, mean(gains.iter().copied()), "the mean is the seed's mean, as before");
    assert_eq!(cc.diff_ci95, Some([cc.diff_mean - half, cc.diff_mean + half]));
    assert!(s.localisation.error_diff_ci95_m.is_some());
    let json = serde_json::to_string(&s).expect("json");
    assert!(json.contains("\"interval_units\":\"world-batches\""), "{json}");

    let md = report_md(&s);
    assert!(md.contains("95 % CI over 10 batches of seed 11's worlds"), "{md}");
    assert!(md.contains("batch means"), "{md}");
    assert!(md.contains("a verdict on this chain"), "the claims say what the interval covers: {md}");
    assert!(s.table().contains("95 % CI over 10 batches of seed 11's worlds"));
}

#[test]
fn several_seeds_keep_the_interval_over_seeds_and_few_worlds_get_none() {
    let base = record().seeds.remove(0);
    let r = with_seeds(vec![seed(&base, 11, 99, wandering), seed(&base, 12, 99, |i| wandering(i) + 1.0)]);
    let s = r.summary();
    assert_eq!(s.interval_units, IntervalUnits::Seeds);
    let per_seed: Vec<f64> =
        r.seeds.iter().map(|x| mean(x.rows.iter().map(|w| w.updated_map.cc - w.static_map.cc))).collect();
    assert_eq!(s.map_quality.cc.diff_ci95, paired_diff(&per_seed).ci95, "bit for bit the paired interval");
    assert!(report_md(&s).contains("95 % CI over 2 seeds"));

    // One seed of 19 updated worlds: too few for 10 batches of 2.
    let s = with_seeds(vec![seed(&base, 11, 19, wandering)]).summary();
    assert_eq!((s.interval_units, s.map_quality.cc.diff_ci95), (IntervalUnits::Seeds, None));
    let md = report_md(&s);
    assert!(md.contains("1 seed: none") && md.contains("--worlds 21 or more"), "{md}");
}

#[test]
fn two_presets_on_one_seed_are_compared_world_by_world() {
    let base = record().seeds.remove(0);
    let mut a = with_seeds(vec![seed(&base, 11, 99, wandering)]);
    let mut b = with_seeds(vec![seed(&base, 11, 99, |i| wandering(i) - 2.0 + (i % 3) as f64)]);
    a.params.preset = "mapkeeper".into();
    b.params.preset = "paper".into();
    let presets = vec!["paper".to_string(), "mapkeeper".to_string()];
    let c = Comparison::new(&presets, &[&b, &a]);
    let d = &c.preset_diffs[0];
    assert_eq!((d.a.as_str(), d.b.as_str()), ("mapkeeper", "paper"));
    assert_eq!(d.interval_units, IntervalUnits::WorldBatches);
    let by_world: Vec<f64> =
        a.seeds[0].rows.iter().zip(&b.seeds[0].rows).map(|(x, y)| x.updated_map.cc - y.updated_map.cc).collect();
    let half = batch_means_half_width(&by_world).expect("batches");
    let [lo, hi] = d.cc.ci95.expect("an interval");
    assert!(((hi - lo) / 2.0 - half).abs() < 1e-9 && ((lo + hi) / 2.0 - d.cc.mean).abs() < 1e-9);
    assert!(c.report_md().contains("| mapkeeper − paper | 1, worlds |"), "{}", c.report_md());

    // With two common seeds the seeds are the units again.
    let two = |r: &ValidationRecord, shift: f64| {
        let mut r = r.clone();
        let mut extra = r.seeds[0].clone();
        extra.seed = 12;
        for w in &mut extra.rows {
            w.seed = 12;
            w.updated_map.cc += shift;
        }
        r.seeds.push(extra);
        r
    };
    let c = Comparison::new(&presets, &[&two(&b, 0.0), &two(&a, 1.0)]);
    assert_eq!(c.preset_diffs[0].interval_units, IntervalUnits::Seeds);
}

/// A one-seed folder written before `interval_units` (no key, no intervals) still reads: its
/// summary is checked against the summary as those versions made it; a doctored one is not.
#[test]
fn a_one_seed_summary_from_before_interval_units_still_matches_its_runs() {
    let base = record().seeds.remove(0);
    let r = with_seeds(vec![seed(&base, 11, 30, wandering)]);
    let dir = std::path::Path::new("a-folder");
    let now = serde_json::to_value(r.summary()).expect("json");
    assert!(check_summary_json(dir, &r, &now.to_string()).is_ok());

    let mut old = serde_json::to_value(r.summary().without_one_seed_intervals()).expect("json");
    old.as_object_mut().expect("an object").remove("interval_units");
    assert!(check_summary_json(dir, &r, &old.to_string()).is_ok(), "written before interval_units");
    // The old form with the key present is not what this version writes.
    let mut keyed = serde_json::to_value(r.summary().without_one_seed_intervals()).expect("json");
    keyed["interval_units"] = "seeds".into();
    assert!(check_summary_json(dir, &r, &keyed.to_string()).is_err());
    // Nor is an old summary with other numbers.
    old["map_quality"]["cc"]["diff_mean"] = 1.0.into();
    assert!(check_summary_json(dir, &r, &old.to_string()).is_err());
}
