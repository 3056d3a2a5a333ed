use super::*;
use crate::experiments::real_scans::chain::{PassScores, Restored};
use crate::experiments::reference::ErrorStats;

fn scores(v: f64) -> MapScores {
    MapScores { cc: v, ms: v - 10.0, opdf: v + 5.0 }
}

fn pass(k: usize, v: f64, retention: f64, restored: f64, error: Option<f64>) -> PassScores {
    PassScores {
        pass: k,
        scores: scores(v),
        fresh: scores(v - 1.0),
        retention,
        restored: Restored { added: Some(restored), removed: Some(restored + 10.0), moved: None },
        pose_error: error.map(|e| ErrorStats {
            estimates: 10,
            rmse_m: e,
            max_m: 2.0 * e,
            median_m: e,
            p95_m: e,
            yaw_rmse_deg: 1.0,
            lost_share: 0.0,
            targets_met: true,
        }),
        verdicts: (10, 0, 0),
        lost_episodes: 1,
        cells_changed: 5,
    }
}

fn chain(poses: &str, seed: u64, m1: f64, passes: &[f64], retention: f64, error: Option<f64>) -> ChainResult {
    let per_pass: Vec<PassScores> =
        passes.iter().enumerate().map(|(i, &v)| pass(i + 2, v, retention, 50.0 + v - 80.0, error)).collect();
    let k = per_pass.last().unwrap().clone();
    ChainResult {
        log: "log".into(),
        edit_seed: seed,
        preset: "mapkeeper".into(),
        poses: poses.into(),
        m1: scores(m1),
        last: k.scores,
        fresh: k.fresh,
        oracle: scores(100.0),
        retention: k.retention,
        restored: k.restored,
        structure_cells: 100,
        class_cells: (10, 10, 0),
        per_pass,
        maps: Vec::new(),
    }
}

#[test]
fn a_hand_computed_case() {
    // Two seeds at the reference poses (gains 10 and 12) and with a localiser (gains 8 and 10,
    // the second decaying after pass 3).
    let chains = vec![
        chain("reference", 1, 70.0, &[75.0, 78.0, 80.0], 100.0, None),
        chain("reference", 2, 70.0, &[76.0, 80.0, 82.0], 99.5, None),
        chain("amcl", 1, 70.0, &[74.0, 77.0, 78.0], 99.0, Some(0.1)),
        chain("amcl", 2, 70.0, &[74.0, 81.0, 80.0], 98.0, Some(0.3)),
    ];
    let sources = vec![
        PoseSourceConfig::Reference,
        PoseSourceConfig::Localiser {
            name: "amcl".into(),
            params: Box::new(mapkeeper_localiser::FilterParams::amcl()),
        },
    ];
    let s = summarise(&chains, &["mapkeeper".to_string()], &sources);
    assert_eq!(s.len(), 2);
    let (r, a) = (&s[0], &s[1]);
    assert_eq!((r.poses.as_str(), a.poses.as_str(), a.seeds), ("reference", "amcl", 2));
    // Means.
    assert_eq!((r.m1.cc, r.pass2.cc, r.last.cc, r.fresh.cc), (70.0, 75.5, 81.0, 80.0));
    assert_eq!((r.last.ms, r.last.opdf), (71.0, 86.0));
    // Gains 10 and 12: mean 11, interval 11 ± t(0.975, 1) · 1/√2 · √2 = 11 ± 12.706.
    assert_eq!(r.gain.cc.mean, 11.0);
    let [lo, hi] = r.gain.cc.ci95.unwrap();
    assert!((lo - (11.0 - 12.7062)).abs() < 1e-3 && (hi - (11.0 + 12.7062)).abs() < 1e-3, "{lo} {hi}");
    // amcl: gains 8 and 10, mean 9; 9 / 11 of the reference's.
    assert_eq!(a.gain.cc.mean, 9.0);
    let ratio = a.gain_ratio.unwrap();
    assert!((ratio.cc - 9.0 / 11.0).abs() < 1e-12 && (ratio.ms - 9.0 / 11.0).abs() < 1e-12);
    assert!(r.gain_ratio.is_none());
    // Seed 2 of amcl ends below its pass 3 (80 < 81).
    assert_eq!((a.decayed_seeds, r.decayed_seeds), (1, 0));
    assert_eq!(a.since_pass3.cc.mean, 0.0); // +1 and −1
    // Retention: mean and least.
    assert_eq!((a.retention, a.retention_min), (98.5, 98.0));
    // Restored at pass K: 50 + v − 80 for added, +10 for removed; moved had no cells.
    assert_eq!(a.restored.added, Some(49.0));
    assert_eq!(a.restored.removed, Some(59.0));
    assert_eq!(a.restored.moved, None);
    // Pose errors over the passes and seeds: RMSE mean 0.2, largest 0.6.
    assert!((a.pose_rmse_m.unwrap() - 0.2).abs() < 1e-12 && a.pose_max_m == Some(0.6));
    assert_eq!(r.pose_rmse_m, None);
    assert_eq!(a.lost_episodes, 6);
    // Pass K against the fresh map: 1 point above on every metric.
    assert_eq!(a.over_fresh.ms.mean, 1.0);
    // Verdicts: two seeds give intervals that straddle 0 here; ratio below 0.9; decay;
    // retention below 99; restored below 80.
    assert_eq!(
        a.verdicts,
        Verdicts {
            better_than_m1: false,
            gain_as_reference: Some(false),
            no_decay: false,
            retention: false,
            restored: false
        }
    );
    assert!(r.verdicts.no_decay && r.verdicts.retention && r.verdicts.gain_as_reference.is_none());
}

#[test]
fn one_seed_has_no_interval_and_counts_its_mean() {
    let chains = vec![chain("reference", 1, 70.0, &[75.0, 78.0], 100.0, None)];
    let s = summarise(&chains, &["mapkeeper".to_string()], &[PoseSourceConfig::Reference]);
    assert_eq!(s[0].gain.cc.ci95, None);
    assert!(s[0].verdicts.better_than_m1);
}
