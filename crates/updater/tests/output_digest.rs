//! Regression for speed work: the updater's outputs over fixed scenarios of the benchmark scene
//! (every step's verdict, n, n_dc, cell changes and pose recovery, the buffered cells after each
//! step, each beam's class and hit point, the final map and the running totals) are pinned by
//! digest. An optimisation must leave them bit-identical; a deliberate behaviour change
//! re-records them (the failure message prints the new values).

mod common;

use common::digest::{SCENARIOS, scenario_digest};

/// Digests of the `paper` preset with the removal-vote additions (re-recorded when the speed
/// work was merged with them; the merge left the validation's maps bit-identical), in the order
/// of `SCENARIOS`.
const EXPECTED: [u64; 4] = [0x15b6_2fc5_c9e5_9bdd, 0x0df9_5d23_72a8_cb8d, 0x7dee_609d_72e5_f669, 0xf578_a63c_ff5a_2571];

#[test]
fn updater_outputs_match_pinned_digests() {
    let got: Vec<(u64, usize)> = SCENARIOS.iter().map(scenario_digest).collect();
    for (s, (digest, processed)) in SCENARIOS.iter().zip(&got) {
        println!("{}: {digest:#018x} ({processed} of {} steps processed)", s.name, s.steps);
        assert!(*processed * 10 >= s.steps * 8, "{}: only {processed} of {} steps processed", s.name, s.steps);
    }
    let digests: Vec<String> = got.iter().map(|(d, _)| format!("{d:#018x}")).collect();
    assert_eq!(
        got.iter().map(|g| g.0).collect::<Vec<_>>(),
        EXPECTED,
        "updater outputs changed; if deliberate, set EXPECTED to [{}]",
        digests.join(", ")
    );
}
