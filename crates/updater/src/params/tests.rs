//! The presets, the validation and the serde of [`UpdaterParams`].
#![allow(clippy::unwrap_used)]

use super::*;

#[test]
fn presets_validate_and_differ_as_listed() {
    for name in PRESET_NAMES {
        UpdaterParams::preset(name).unwrap().validate().unwrap();
    }
    assert!(matches!(UpdaterParams::preset("nope"), Err(UpdaterError::UnknownPreset { .. })));
    let r = UpdaterParams::authors();
    // 0.013z + 0.15, uncapped.
    assert!((r.tol_m(100.0) - 1.45).abs() < 1e-12);
    let p = UpdaterParams::paper_strict();
    assert!((p.tol_m(100.0) - 0.20).abs() < 1e-12);
    assert!((p.tol_m(5.0) - 0.15).abs() < 1e-12);
    // D_th saturates at 0.30.
    assert!((p.change_distance_m(1.0) - 0.16057).abs() < 1e-12);
    assert!((p.change_distance_m(30.0) - 0.30).abs() < 1e-12);
    // Eq. 9: the final chunk is m·z in `paper-strict`; `paper` and `authors` floor it at 0.15 m.
    assert!((p.skip_changed_m(2.0) - 0.04).abs() < 1e-12);
    assert!((p.skip_changed_m(10.0) - 0.20).abs() < 1e-12);
    assert!((r.skip_changed_m(2.0) - 0.15).abs() < 1e-12);
    // `paper` differs from `paper-strict` at exactly the five open points.
    let fair = UpdaterParams::paper();
    assert!((fair.skip_changed_m(2.0) - 0.15).abs() < 1e-12 && (fair.skip_unchanged_m(2.0) - 0.15).abs() < 1e-12);
    assert_eq!((fair.revert, fair.change_threshold), (RevertRule::BelowThreshold, 8));
    assert_eq!((fair.virtual_rays_each_side, fair.virtual_ray_spacing_beams), (3, 0.25));
    assert!(fair.border_interior_only);
    let back = UpdaterParams {
        revert: p.revert,
        change_threshold: p.change_threshold,
        skip_changed_min_m: 0.0,
        skip_unchanged_min_m: 0.0,
        virtual_rays_each_side: 1,
        virtual_ray_spacing_beams: 0.5,
        border_interior_only: false,
        ..fair
    };
    assert_eq!(back, p);
    // `paper-strict` has none of the additions; `mapkeeper` has them all.
    let m = UpdaterParams::mapkeeper();
    assert!(!p.free_pass_votes && !p.removal.shadow && !p.border_interior_only);
    assert_eq!(
        (p.revert, r.revert, UpdaterParams::mapkeeper().revert),
        (RevertRule::Never, RevertRule::BelowThreshold, RevertRule::UnchangedThreshold)
    );
    assert_eq!(p.removal, RemovalParams::default());
    assert!(p.removal.hit_clearance_m == 0.0 && p.removal.min_incidence_rad == 0.0);
    assert!(p.removal.max_offset_cells.is_infinite() && m.removal.max_offset_cells.is_infinite());
    assert!(m.free_pass_votes && m.removal.shadow && m.border_interior_only);
    assert_eq!(UpdaterParams { skip_changed_min_m: 0.0, ..m.clone() }.removal.hit_clearance_m, 0.20);
    assert!(m.registration.enabled && m.memory.enabled);
    assert!(m.shift_check.enabled && m.shift_check.when == ShiftWhen::OnAlarm);
    assert!(m.global_search.enabled && !p.global_search.enabled && !r.global_search.enabled);
    // `mapkeeper-evidence` is `mapkeeper` with the surface evidence and registration to cell
    // centres.
    let e = UpdaterParams::mapkeeper_evidence();
    assert!(e.evidence.enabled && !m.evidence.enabled && e.registration.pull_to_centres);
    assert!(!m.registration.pull_to_centres);
    let back = UpdaterParams {
        evidence: m.evidence,
        registration: RegistrationParams { pull_to_centres: false, ..e.registration },
        ..e.clone()
    };
    assert_eq!(back, m);
    let n = UpdaterParams::mapkeeper_no_registration();
    let without = UpdaterParams {
        registration: n.registration,
        memory: n.memory,
        shift_check: n.shift_check,
        global_search: n.global_search,
        ..m.clone()
    };
    assert_eq!(without, n);
    // `mapkeeper-shift` is `mapkeeper` with the shift check on every step.
    let s = UpdaterParams::mapkeeper_shift();
    assert_eq!(s.shift_check.when, ShiftWhen::EveryStep);
    assert_eq!(UpdaterParams { shift_check: m.shift_check, ..s }, m);
    assert!(!UpdaterParams::always_update().localisation_check);
    assert!(!UpdaterParams::no_update().map_update);
}

#[test]
fn validate_rejects_bad_fields() {
    let mut p = UpdaterParams::paper();
    p.change_threshold = 11;
    assert!(matches!(p.validate(), Err(UpdaterError::InvalidParam(e)) if e.name == "change_threshold"));
    // Flip and flip back would both hold with a threshold of at most N_b / 2.
    let mut p = UpdaterParams::mapkeeper();
    p.change_threshold = 5;
    let err = p.validate().unwrap_err().to_string();
    assert!(err.contains("change_threshold") && err.contains("unchanged-threshold"), "{err}");
    p.change_threshold = 6;
    assert!(p.validate().is_ok());
    p.revert = RevertRule::BelowThreshold;
    p.change_threshold = 3;
    assert!(p.validate().is_ok());
    let mut p = UpdaterParams::paper();
    p.min_valid_beams = 0;
    assert!(p.validate().is_err());
    let mut p = UpdaterParams::paper();
    p.d_eps_min = 0.95;
    assert!(p.validate().is_err());
    let mut p = UpdaterParams::paper();
    p.buffer_size = 40;
    assert!(p.validate().is_err());
    let mut p = UpdaterParams::paper();
    p.change_slope = f64::NAN;
    assert!(p.validate().is_err());
}

/// `skip_unchanged_slope = 1` was refused as "skip_changed_slope: skip slopes must be < 1",
/// naming the other field (found by the edge-value sweep of the `updater_params` replay
/// test).
#[test]
fn a_skip_unchanged_slope_of_one_is_refused_under_its_own_name() {
    let p = UpdaterParams { skip_unchanged_slope: 1.0, ..UpdaterParams::paper() };
    let e = p.validate().unwrap_err();
    assert!(matches!(&e, UpdaterError::InvalidParam(p) if p.name == "skip_unchanged_slope"), "{e}");
    let p = UpdaterParams { skip_changed_slope: 1.5, ..UpdaterParams::paper() };
    assert_eq!(
        p.validate().unwrap_err().to_string(),
        "invalid updater parameter 'skip_changed_slope': must be < 1, got 1.5"
    );
}

/// A refusal names the field (a section's by its dotted path), the value and the
/// requirement.
#[test]
fn a_refusal_names_the_field_the_value_and_the_requirement() {
    let e = UpdaterParams { buffer_size: 40, ..UpdaterParams::paper() }.validate().unwrap_err();
    assert_eq!(e, UpdaterError::InvalidParam(ParamError::new("buffer_size", 40, "must lie in 1..=32")));
    assert_eq!(e.to_string(), "invalid updater parameter 'buffer_size': must lie in 1..=32, got 40");
    let mut p = UpdaterParams::paper();
    p.log_odds.l_occ = -1.0;
    assert_eq!(
        p.validate().unwrap_err().to_string(),
        "invalid updater parameter 'log_odds.l_occ': must be a finite number > 0, got -1"
    );
    let mut p = UpdaterParams::mapkeeper();
    p.shift_check.step_xy_m = 0.0;
    assert_eq!(
        p.validate().unwrap_err().to_string(),
        "invalid updater parameter 'shift_check.step_xy_m': must be finite and > 0, got 0"
    );
    let mut p = UpdaterParams::mapkeeper();
    p.pose_updating.source_beam_step = 0;
    assert_eq!(
        p.validate().unwrap_err().to_string(),
        "invalid updater parameter 'pose_updating.source_beam_step': must be >= 1"
    );
}

#[test]
fn infinite_limits_survive_json() {
    for name in PRESET_NAMES {
        let p = UpdaterParams::preset(name).unwrap();
        let json = serde_json::to_string(&p).unwrap();
        assert_eq!(serde_json::from_str::<UpdaterParams>(&json).unwrap(), p, "{json}");
    }
    assert!(serde_json::to_string(&UpdaterParams::paper()).unwrap().contains(r#""max_range_m":"inf""#));
    let p: UpdaterParams = serde_json::from_str(r#"{"tol_max_m": null, "max_range_m": 18.0}"#).unwrap();
    assert_eq!((p.tol_max_m, p.max_range_m), (f64::INFINITY, 18.0));
    let p: UpdaterParams = serde_json::from_str(r#"{"max_range_m": "Infinity"}"#).unwrap();
    assert_eq!(p.max_range_m, f64::INFINITY);
    assert!(serde_json::from_str::<UpdaterParams>(r#"{"tol_max_m": "far"}"#).is_err());
}

#[test]
fn serde_overrides_one_field_and_rejects_unknown() {
    let p: UpdaterParams =
        serde_json::from_str(r#"{"buffer_size": 12, "pose_updating": {"max_rmse_m": 0.1}}"#).unwrap();
    assert_eq!(p.buffer_size, 12);
    assert_eq!(p.change_threshold, 8);
    assert_eq!(p.pose_updating.max_rmse_m, 0.1);
    assert!(serde_json::from_str::<UpdaterParams>(r#"{"bufer_size": 12}"#).is_err());
}
