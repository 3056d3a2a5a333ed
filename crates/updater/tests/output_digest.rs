//! Regression for speed work: the updater's outputs over fixed scenarios of the benchmark scene
//! (every step's verdict, n, n_dc, cell changes and pose recovery, the buffered cells after each
//! step, each beam's class and hit point, the final map and the running totals) are pinned by
//! digest. An optimisation must leave them bit-identical; a deliberate behaviour change
//! re-records them (the failure message prints the new values).

mod common;

use common::digest::{SCENARIOS, scenario_digest};

/// Digests in the order of `SCENARIOS`. The first five were recorded when the presets were split
/// into `paper`, `authors` and `mapkeeper` and the localisation check began to run on every scan,
/// and are unchanged by the third release's renaming (`paper` → `paper-strict`, `mapkeeper` →
/// `mapkeeper-no-registration`); the next three are the third release's `paper` (read fairly)
/// and `mapkeeper` (with registration and the memory); the last two issue 53's
/// `mapkeeper-evidence` (the surface evidence, registration to cell centres).
const EXPECTED: [u64; 10] = [
    0x9c49_f2bb_3f6e_a6d1,
    0x890d_cce4_f42e_7a3e,
    0xa7c7_2f67_f5b7_0449,
    0x7147_3925_2c0c_8662,
    0x36c7_14cd_c21a_fcc0,
    0xdff9_9e3f_61a4_18d4,
    0x2810_5493_d062_5a99,
    0x9b38_6f3b_798e_e3d8,
    0xb96f_4b31_26db_2edc,
    0xc74d_e0a6_30e6_f977,
];

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
