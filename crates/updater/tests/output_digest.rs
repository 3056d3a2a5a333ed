//! Regression for speed work: the updater's outputs over fixed scenarios of the benchmark scene
//! (every step's verdict, n, n_dc, cell changes and pose recovery, the buffered cells after each
//! step, each beam's class and hit point, the final map and the running totals) are pinned by
//! digest. An optimisation must leave them bit-identical; a deliberate behaviour change
//! re-records them (the failure message prints the new values).

mod common;

use common::digest::{SCENARIOS, scenario_digest};

/// Digests recorded before the speed work (commit 6142af9), in the order of `SCENARIOS`.
const EXPECTED: [u64; 4] = [0x94b1_00f0_99ac_1b9f, 0xf784_5f96_7359_fcf2, 0x9853_84be_55ab_6b5a, 0x9ff0_7e19_9baf_bb4b];

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
