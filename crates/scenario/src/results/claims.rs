//! The paper's claims beside the results (issue 12, item 9): every report ends with a table of
//! the claims its experiment tests, each with the measured result and a verdict computed from
//! it (reproduced, not reproduced, differs, or inconclusive) and why. The verdict rules are here,
//! in one place, and the thresholds the paper does not give are named in the "why".

use crate::stats::{IntervalUnits, with_ci};
use std::fmt::Write as _;

/// What a result says of a claim.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClaimVerdict {
    /// The result agrees with the claim.
    Reproduced,
    /// The result contradicts it.
    NotReproduced,
    /// The effect is there, but smaller, partial, or not as the paper states it.
    Differs,
    /// The run cannot tell (one seed where an interval is needed, no trials).
    Inconclusive,
}

impl ClaimVerdict {
    /// The word in the table.
    pub fn name(self) -> &'static str {
        match self {
            ClaimVerdict::Reproduced => "reproduced",
            ClaimVerdict::NotReproduced => "not reproduced",
            ClaimVerdict::Differs => "differs",
            ClaimVerdict::Inconclusive => "inconclusive",
        }
    }
}

/// One claim of the paper and what this run found.
#[derive(Clone, Debug, PartialEq)]
pub struct Claim {
    /// The claim, with where the paper makes it.
    pub claim: String,
    /// The measured result.
    pub result: String,
    /// The verdict.
    pub verdict: ClaimVerdict,
    /// Why this verdict (the rule applied).
    pub why: String,
}

/// The sign of a paired difference by its 95 % interval: `Some(1)` above 0, `Some(-1)` below,
/// `Some(0)` spanning it, `None` without an interval.
pub fn sign_by_interval(ci: Option<[f64; 2]>) -> Option<i8> {
    ci.map(|[lo, hi]| {
        if lo > 0.0 {
            1
        } else if hi < 0.0 {
            -1
        } else {
            0
        }
    })
}

/// The verdict on "B is better than A" from the paired difference B − A (positive = better) and
/// its interval, and whether the paper also claims "in every world/trial" (`share` of units where
/// B was better, checked when `every` is set).
pub fn better_verdict(mean: f64, ci: Option<[f64; 2]>, share: Option<f64>, every: bool) -> (ClaimVerdict, String) {
    let every_met = share.is_none_or(|s| s >= 1.0);
    match sign_by_interval(ci) {
        Some(1) if !every || every_met => {
            (ClaimVerdict::Reproduced, "the 95 % interval of the difference lies above 0".into())
        }
        Some(1) => (
            ClaimVerdict::Differs,
            format!(
                "better on average (interval above 0) but not in every world ({:.0} %)",
                100.0 * share.unwrap_or(0.0)
            ),
        ),
        Some(-1) => (ClaimVerdict::NotReproduced, "the 95 % interval lies below 0: worse, not better".into()),
        Some(_) if mean > 0.0 && share.is_some_and(|s| s >= 1.0) => (
            ClaimVerdict::Inconclusive,
            "better in every unit of this run, but the 95 % interval spans 0: more seeds needed".into(),
        ),
        Some(_) => (ClaimVerdict::NotReproduced, "the 95 % interval spans 0: no difference shown".into()),
        None if mean > 0.0 && every && every_met => {
            (ClaimVerdict::Reproduced, "better in every world (one seed: no interval)".into())
        }
        None if mean < 0.0 && share.is_some_and(|s| s == 0.0) => {
            (ClaimVerdict::NotReproduced, "worse in every world (one seed: no interval)".into())
        }
        None => (ClaimVerdict::Inconclusive, "one seed gives no interval: run with --seeds 3 or more".into()),
    }
}

/// A rate against a target the paper does not state: reproduced at or above `good`, differs
/// from `fair` up, not reproduced below.
pub fn rate_verdict(rate: f64, good: f64, fair: f64, what: &str) -> (ClaimVerdict, String) {
    if rate >= good {
        (
            ClaimVerdict::Reproduced,
            format!("{what} {:.1} % ≥ {:.0} % (the project's threshold)", 100.0 * rate, 100.0 * good),
        )
    } else if rate >= fair {
        (
            ClaimVerdict::Differs,
            format!(
                "{what} {:.1} %: between {:.0} % and {:.0} % (the project's thresholds)",
                100.0 * rate,
                100.0 * fair,
                100.0 * good
            ),
        )
    } else {
        (
            ClaimVerdict::NotReproduced,
            format!("{what} {:.1} % < {:.0} % (the project's threshold)", 100.0 * rate, 100.0 * fair),
        )
    }
}

/// The claims section of a report.
pub fn claims_md(claims: &[Claim]) -> String {
    let mut s = String::from(
        "\n## The paper's claims beside this run\n\nEach verdict is computed from the figures of this run by \
the rule in its last column (`crates/scenario/src/results/claims.rs`).\n\n| claim (paper) | this run | verdict | why |\n|---|---|---|---|\n",
    );
    for c in claims {
        let cell = |t: &str| t.replace('|', "\\|").replace('\n', " ");
        let _ =
            writeln!(s, "| {} | {} | **{}** | {} |", cell(&c.claim), cell(&c.result), c.verdict.name(), cell(&c.why));
    }
    s
}

/// Several verdicts on the parts of one claim (e.g. three metrics) as one: all reproduced →
/// reproduced; none → the first part's; else differs.
fn combine(parts: &[ClaimVerdict]) -> ClaimVerdict {
    if parts.iter().all(|v| *v == ClaimVerdict::Reproduced) {
        ClaimVerdict::Reproduced
    } else if parts.iter().all(|v| *v != ClaimVerdict::Reproduced) {
        parts.first().copied().unwrap_or(ClaimVerdict::Inconclusive)
    } else {
        ClaimVerdict::Differs
    }
}

/// The validation's claims (§5.3.2, Fig. 24-25).
pub fn validation_claims(s: &crate::experiments::validation::Summary) -> Vec<Claim> {
    let q = &s.map_quality;
    let mut claims = Vec::new();
    // With one seed the interval is over its worlds: a verdict on this chain, which another
    // seed's chain may not share.
    let scope = |(verdict, why): (ClaimVerdict, String)| match s.interval_units {
        IntervalUnits::WorldBatches if s.map_quality.cc.diff_ci95.is_some() => (
            verdict,
            format!("{why} (interval over this seed's worlds: a verdict on this chain; --seeds 3 for one over seeds)"),
        ),
        _ => (verdict, why),
    };
    for (name, m) in [("CC", &q.cc), ("MS", &q.ms), ("OPDF", &q.opdf)] {
        let (verdict, why) = scope(better_verdict(m.diff_mean, m.diff_ci95, Some(m.updated_better_fraction), true));
        claims.push(Claim {
            claim: format!("§5.3.2, Fig. 24: M_i/G_i is above M_1/G_i in every world ({name})"),
            result: format!(
                "M_i − M_1 {} points (95 % CI over {}); M_i better in {:.0} % of worlds",
                with_ci(m.diff_mean, m.diff_ci95, 2),
                s.interval_over(),
                100.0 * m.updated_better_fraction
            ),
            verdict,
            why,
        });
    }
    let l = &s.localisation;
    // error_diff is chain − baseline (negative = the chain on M_{i-1} is better): flip it.
    let gain = -l.error_diff_mean_m;
    let ci = l.error_diff_ci95_m.map(|[lo, hi]| [-hi, -lo]);
    let (verdict, why) = scope(better_verdict(gain, ci, Some(l.updated_better_fraction), false));
    claims.push(Claim {
        claim: "§5.3.2, Fig. 25: localising on M_{i-1} gives lower position errors than on M_1".into(),
        result: format!(
            "mean error on M_1 − on M_{{i-1}}: {} m (95 % CI over {}); lower on M_{{i-1}} in {:.0} % of worlds",
            with_ci(gain, ci, 4),
            s.interval_over(),
            100.0 * l.updated_better_fraction
        ),
        verdict,
        why,
    });
    let (verdict, why) =
        rate_verdict(l.updated_lower_trace_fraction, 0.9, 0.5, "worlds with a lower covariance trace on M_{i-1}:");
    claims.push(Claim {
        claim: "§5.3.2, Fig. 26: the covariance (trace, λmax) is lower on M_{i-1} than on M_1".into(),
        result: format!(
            "mean trace {:.4} on M_1, {:.4} on M_{{i-1}}",
            l.static_map.mean_trace, l.updated_map.mean_trace
        ),
        verdict,
        why,
    });
    if let Some(h) = &s.heavy_change {
        let alarms = h.suspend_share + h.lost_share;
        let (verdict, why) = if h.stuck_worlds > 0 || alarms > 0.05 {
            (
                ClaimVerdict::Reproduced,
                "the check held back a well-localised robot (stuck worlds, or > 5 % Suspend/Lost)".into(),
            )
        } else {
            (ClaimVerdict::Differs, "the limit did not show: no stuck world and ≤ 5 % Suspend/Lost".into())
        };
        claims.push(Claim {
            claim: format!(
                "§6 (the paper's admitted limit): after heavy change (every {}th world updated) the check keeps a \
well-localised robot from updating",
                h.update_every
            ),
            result: format!(
                "Suspend {:.2} %, Lost {:.2} % of the processed steps of {} updated world runs (chain error {:.3} m); {} stuck \
worlds (longest run {})",
                100.0 * h.suspend_share,
                100.0 * h.lost_share,
                h.update_worlds,
                h.mean_error_m,
                h.stuck_worlds,
                h.longest_stuck_run
            ),
            verdict,
            why,
        });
    }
    claims
}

/// Table 1's claims (§5.4), per preset: the check against always-update when the localiser starts
/// wrong (the paper's setting) and under the longest held error.
pub fn table1_claims(s: &crate::experiments::table1_hold::Table1HoldSummary) -> Vec<Claim> {
    let mut claims = Vec::new();
    let longest = s.params.holds_s.iter().copied().fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))));
    for (preset, by_cond) in &s.table1 {
        let mut conds: Vec<(String, String)> = vec![(
            "amcl_start".into(),
            format!(
                "Table 1 (§5.4): with the localisation check M_2/G_2 beats always-update when the localiser starts wrong \
(paper: CC 66.86 → 70.03, MS 55.11 → 61.24, OPDF 90.40 → 95.87); preset `{preset}`"
            ),
        )];
        if let Some(h) = longest.filter(|h| *h > 0.0) {
            conds.push((
                crate::experiments::table1_hold::hold_name(h),
                format!("§4.2, §5.4: the check keeps a wrong pose from damaging the map (pose held wrong {h} s); preset `{preset}`"),
            ));
        }
        for (cond, claim) in conds {
            let Some(cell) = by_cond.get(&cond).and_then(|v| v.get("check")) else { continue };
            let mut parts = Vec::new();
            let mut result = Vec::new();
            for m in ["cc", "ms", "opdf"] {
                let Some(d) = cell.vs_always_update.get(m) else { continue };
                parts.push(better_verdict(d.mean, d.ci95, None, false).0);
                result.push(format!("{} {}", m.to_uppercase(), with_ci(d.mean, d.ci95, 2)));
            }
            let verdict = combine(&parts);
            claims.push(Claim {
                claim,
                result: format!("check − always-update over {} trials: {}", cell.runs, result.join(", ")),
                verdict,
                why: "per metric: the paired 95 % interval over the trials above 0; all three metrics → reproduced, some → differs".into(),
            });
        }
    }
    claims
}

/// The check-detection claims (§4.2), per preset.
pub fn check_detection_claims(s: &crate::experiments::check_detection::CheckDetectionSummary) -> Vec<Claim> {
    let mut claims = Vec::new();
    for (preset, d) in &s.check_detection {
        let (verdict, why) = rate_verdict(d.detection_rate, 0.95, 0.5, "detection");
        claims.push(Claim {
            claim: format!("§4.2: the localisation check detects a mislocalised robot (errors ≥ 0.3 m, within 2 s); preset `{preset}`"),
            result: format!("{} of {} detected", d.detection.hits, d.detection.of),
            verdict,
            why,
        });
        let fa = d.false_alarm_rate;
        let (verdict, why) = if fa <= 0.01 {
            (ClaimVerdict::Reproduced, format!("false alarms {:.2} % ≤ 1 % (the project's threshold)", 100.0 * fa))
        } else if fa <= 0.05 {
            (
                ClaimVerdict::Differs,
                format!("false alarms {:.2} %: between 1 % and 5 % (the project's thresholds)", 100.0 * fa),
            )
        } else {
            (ClaimVerdict::NotReproduced, format!("false alarms {:.2} % > 5 % (the project's threshold)", 100.0 * fa))
        };
        claims.push(Claim {
            claim: format!("§4.2, §5.3: a well-localised robot keeps updating (no Suspend/Lost on right poses, ≤ 0.05 m); preset `{preset}`"),
            result: format!("{} alarms on {} right-pose steps", d.false_alarms.hits, d.false_alarms.of),
            verdict,
            why,
        });
    }
    claims
}

/// The kidnap claims (§4.6).
pub fn kidnap_claims(k: &crate::experiments::kidnap_robot::KidnapRobotSummary) -> Vec<Claim> {
    let (verdict, why) = rate_verdict(k.recovered_rate_pose_updating, 0.9, 0.5, "recovered by pose updating");
    let mut claims = vec![Claim {
        claim: format!(
            "§4.6: pose updating recovers the robot's pose after it is lost (a kidnap); preset `{}`, on {}",
            k.preset,
            k.map.label()
        ),
        result: format!(
            "{} trials: {:.1} % by pose updating, {:.1} % by the filter itself, {:.1} % failed",
            k.applied,
            100.0 * k.recovered_rate_pose_updating,
            100.0 * k.recovered_rate_filter,
            100.0 * k.failed_rate
        ),
        verdict,
        why,
    }];
    let fl = k.false_lost_well_localised_rate;
    let (verdict, why) = if fl <= 0.01 {
        (ClaimVerdict::Reproduced, format!("{:.1} % ≤ 1 % (the project's threshold)", 100.0 * fl))
    } else if fl <= 0.1 {
        (ClaimVerdict::Differs, format!("{:.1} %: between 1 % and 10 % (the project's thresholds)", 100.0 * fl))
    } else {
        (ClaimVerdict::NotReproduced, format!("{:.1} % > 10 % (the project's threshold)", 100.0 * fl))
    };
    claims.push(Claim {
        claim: format!(
            "§4.2, §4.6: a well-localised robot in a stale world is not declared Lost; preset `{}`, on {}",
            k.preset,
            k.map.label()
        ),
        result: format!(
            "the paired runs without a kidnap: Lost while well localised in {:.1} % of them (Lost at all in {:.1} %, \
             while within the success criterion in {:.1} %)",
            100.0 * fl,
            100.0 * k.false_lost_rate,
            100.0 * k.false_lost_right_pose_rate
        ),
        verdict,
        why,
    });
    claims
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_follow_the_intervals_and_the_every_world_clause() {
        assert_eq!(better_verdict(2.0, Some([1.0, 3.0]), Some(1.0), true).0, ClaimVerdict::Reproduced);
        assert_eq!(better_verdict(2.0, Some([1.0, 3.0]), Some(0.9), true).0, ClaimVerdict::Differs);
        assert_eq!(better_verdict(2.0, Some([1.0, 3.0]), Some(0.9), false).0, ClaimVerdict::Reproduced);
        assert_eq!(better_verdict(0.5, Some([-1.0, 2.0]), Some(0.6), true).0, ClaimVerdict::NotReproduced);
        assert_eq!(better_verdict(0.5, Some([-1.0, 2.0]), Some(1.0), true).0, ClaimVerdict::Inconclusive);
        assert_eq!(better_verdict(-3.0, Some([-4.0, -2.0]), Some(0.0), true).0, ClaimVerdict::NotReproduced);
        assert_eq!(better_verdict(1.0, None, Some(1.0), true).0, ClaimVerdict::Reproduced);
        assert_eq!(better_verdict(-1.0, None, Some(0.0), true).0, ClaimVerdict::NotReproduced);
        assert_eq!(better_verdict(1.0, None, Some(0.7), true).0, ClaimVerdict::Inconclusive);
        assert_eq!(rate_verdict(0.96, 0.95, 0.5, "x").0, ClaimVerdict::Reproduced);
        assert_eq!(rate_verdict(0.6, 0.95, 0.5, "x").0, ClaimVerdict::Differs);
        assert_eq!(rate_verdict(0.2, 0.95, 0.5, "x").0, ClaimVerdict::NotReproduced);
        let md = claims_md(&[Claim {
            claim: "a | b".into(),
            result: "r".into(),
            verdict: ClaimVerdict::Differs,
            why: "w".into(),
        }]);
        assert!(md.contains("| a \\| b | r | **differs** | w |"), "{md}");
    }
}
