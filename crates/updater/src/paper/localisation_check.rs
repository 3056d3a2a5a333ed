//! Localisation check (§4.2, eq. 6-8): the share of detected-change beams n_dc among the n
//! valid beams of a step says whether the map may be updated.

use serde::{Deserialize, Serialize};

/// The localisation check's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Eq. 6, n_dc ≤ D_εmin·n: the map update runs.
    Update,
    /// Eq. 7, D_εmin·n < n_dc < D_εmax·n: no map update, keep monitoring.
    Suspend,
    /// Eq. 8, n_dc ≥ D_εmax·n: no map update; pose updating runs.
    Lost,
}

impl Verdict {
    /// Lower-case name (`update`, `suspend`, `lost`).
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Update => "update",
            Verdict::Suspend => "suspend",
            Verdict::Lost => "lost",
        }
    }
}

/// Slack for the products D_ε·n, so that the boundaries fall exactly on 0.75·n and 0.90·n
/// despite binary rounding of 0.9.
const EPS: f64 = 1e-9;

/// Eq. 6-8. The comparisons are inclusive exactly as written: n_dc = D_εmin·n is Update,
/// n_dc = D_εmax·n is Lost. With D_εmin = D_εmax (the `authors` preset) there is no Suspend.
pub fn localisation_check(n: usize, n_dc: usize, d_eps_min: f64, d_eps_max: f64) -> Verdict {
    let (n, n_dc) = (n as f64, n_dc as f64);
    if n_dc <= d_eps_min * n + EPS {
        Verdict::Update
    } else if n_dc >= d_eps_max * n - EPS {
        Verdict::Lost
    } else {
        Verdict::Suspend
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq6_to_8_boundaries_exactly_at_075n_and_090n() {
        for n in [20usize, 100, 1082] {
            let lo = (0.75 * n as f64).floor() as usize;
            let hi = (0.90 * n as f64).ceil() as usize;
            assert_eq!(localisation_check(n, lo, 0.75, 0.90), Verdict::Update, "n={n}");
            assert_eq!(localisation_check(n, lo + 1, 0.75, 0.90), Verdict::Suspend, "n={n}");
            assert_eq!(localisation_check(n, hi - 1, 0.75, 0.90), Verdict::Suspend, "n={n}");
            assert_eq!(localisation_check(n, hi, 0.75, 0.90), Verdict::Lost, "n={n}");
        }
        // n = 100: 75 is exactly 0.75n (Update), 90 exactly 0.90n (Lost).
        assert_eq!(localisation_check(100, 75, 0.75, 0.90), Verdict::Update);
        assert_eq!(localisation_check(100, 76, 0.75, 0.90), Verdict::Suspend);
        assert_eq!(localisation_check(100, 89, 0.75, 0.90), Verdict::Suspend);
        assert_eq!(localisation_check(100, 90, 0.75, 0.90), Verdict::Lost);
        assert_eq!(localisation_check(100, 0, 0.75, 0.90), Verdict::Update);
        // Reference: single threshold.
        assert_eq!(localisation_check(100, 58, 0.58, 0.58), Verdict::Update);
        assert_eq!(localisation_check(100, 59, 0.58, 0.58), Verdict::Lost);
    }
}
