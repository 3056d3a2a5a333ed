//! What `recover` prints of a kidnap suite.

use mapkeeper_scenario::experiments::recovery::KidnapSummary;

pub(super) fn print_kidnap(name: &str, k: &KidnapSummary) {
    let t = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |x| format!("{x:.1} s"));
    outln!(
        "kidnap, {name:<6} {} trials: detected {:.1} %, recovered {:.1} % (≤ 1.5 m: {:.1} % of {}), false Lost \
         {:.1} %, median recovery {}, map damage OPDF {:.3} points (max {:.3}), wrong poses {}/{}",
        k.trials,
        100.0 * k.detected_rate,
        100.0 * k.recovered_rate,
        100.0 * k.recovered_rate_le_1_5m,
        k.trials_le_1_5m,
        100.0 * k.false_lost_rate,
        t(k.median_recovery_s),
        k.map_damage_opdf,
        k.map_damage_opdf_max,
        k.wrong_pose_recoveries,
        k.pose_recoveries
    );
}
