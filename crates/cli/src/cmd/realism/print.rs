//! The table `experiment sensor-realism` prints.

use mapkeeper_scenario::experiments::validation::sensor_realism::SensorRealismResult;

/// Prints the summary table on stdout.
pub(super) fn print_table(r: &SensorRealismResult) {
    outln!(
        "{:<18} {:>9} {:>22} {:>11} {:>9} {:>5}",
        "configuration",
        "CC M_i %",
        "Δ CC vs ideal",
        "mean err m",
        "max err m",
        "Lost"
    );
    for c in &r.summaries {
        outln!(
            "{:<18} {:>9.2} {:>22} {:>11.4} {:>9.3} {:>5}",
            c.config,
            c.cc_updated_mean,
            mapkeeper_scenario::stats::with_ci(c.cc_updated_vs_ideal.mean, c.cc_updated_vs_ideal.ci95, 2),
            c.err_mean_m,
            c.err_max_m,
            c.lost_episodes
        );
    }
}
