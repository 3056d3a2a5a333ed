//! Unit tests of `filter`.

use super::*;

#[test]
fn normalisation_reports_degeneracy() {
    let mut w = Vec::new();
    let (ess, ln_sum) = normalise_log_weights(&[0.0, 3f64.ln()], &mut w).unwrap();
    assert!((w[0] - 0.25).abs() < 1e-15 && (w[1] - 0.75).abs() < 1e-15);
    assert!((ess - 1.0 / 0.625).abs() < 1e-12 && (ln_sum - 4f64.ln()).abs() < 1e-12);
    // Huge negative log-weights do not underflow.
    let (ess, _) = normalise_log_weights(&[-5000.0, -5000.0, f64::NEG_INFINITY], &mut w).unwrap();
    assert!((ess - 2.0).abs() < 1e-12 && w[2] == 0.0);
    // A NaN among finite ones is a zero weight.
    normalise_log_weights(&[f64::NAN, -1.0], &mut w).unwrap();
    assert_eq!(w, vec![0.0, 1.0]);
    let ninf = f64::NEG_INFINITY;
    assert_eq!(normalise_log_weights(&[ninf, ninf], &mut w), Err(Degeneracy::AllWeightsZero));
    assert_eq!(
        normalise_log_weights(&[f64::NAN, ninf, f64::NAN], &mut w),
        Err(Degeneracy::NonFiniteWeights { nan_count: 2 })
    );
    assert_eq!(normalise_log_weights(&[], &mut w), Err(Degeneracy::AllWeightsZero));
}
