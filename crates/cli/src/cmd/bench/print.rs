//! The tables `mapkeeper bench` prints.

use super::*;

/// One row of the table.
#[derive(Debug, Serialize)]
pub(super) struct Row {
    /// What is timed.
    pub(super) what: String,
    /// The unit `median`, `min` and `max` are in.
    pub(super) unit: &'static str,
    pub(super) median: f64,
    pub(super) min: f64,
    pub(super) max: f64,
    /// `median` over the reference's median time (both per repeat).
    pub(super) ratio_to_reference: f64,
    /// Throughput, in `throughput_unit`.
    pub(super) throughput: f64,
    pub(super) throughput_unit: &'static str,
}

pub(super) fn print_table(rows: &[Row], table: &Table, repeats: usize, steps: usize) {
    let reference = median(&table.reference);
    outln!(
        "mapkeeper bench: {steps}-step scene, {repeats} repeat(s); reference workload median {:.2} ms CPU\n",
        reference * 1e3
    );
    outln!("| what | median | min-max | × reference | throughput |");
    outln!("|---|---|---|---|---|");
    for r in rows {
        outln!(
            "| {} | {:.4} {} | {:.4}-{:.4} | {} | {:.1} {} |",
            r.what,
            r.median,
            r.unit,
            r.min,
            r.max,
            significant(r.ratio_to_reference),
            r.throughput,
            r.throughput_unit
        );
    }
}

/// What each localiser did on the scene, beside ROS amcl's own behaviour: how many frames led to
/// a sensor update (`update_min_d` / `update_min_a`), how many particles it carried after one
/// (KLD sampling after convergence) and how many beams it weighted, and the CPU per update: the
/// row's CPU over the updates (prediction-only frames included), the median update's own CPU,
/// and the median CPU per weighted particle and beam (what the filter's arithmetic costs, apart
/// from how many particles it carries).
pub(super) fn print_filter_work(rows: &[Row], keys: &Keys, filters: &[FilterWork], steps: usize) {
    outln!(
        "\nWhat each localiser did on the scene (the counts are the same in every repeat; the CPU of single updates is pooled over the repeats):\n"
    );
    outln!(
        "| localiser | frames | sensor updates | particles after an update: median / max | beams per update: median | CPU per update: all frames / median update | per weighted particle and beam: median |"
    );
    outln!("|---|---|---|---|---|---|---|");
    for ((&key, name), w) in keys.localisers.iter().zip(LOCALISER_PRESETS).zip(filters) {
        let updates = w.particles.len();
        let per_update = match rows.get(key) {
            Some(r) if updates > 0 => format!("{:.3} ms", r.median * steps as f64 / updates as f64),
            _ => "-".into(),
        };
        let (own, per_pb) = if updates > 0 {
            (format!("{:.3} ms", median(&w.update_cpu_s) * 1e3), format!("{:.1} ns", median(&w.ns_per_particle_beam())))
        } else {
            ("-".into(), "-".into())
        };
        outln!(
            "| `{name}` | {} | {updates} | {} / {} | {} | {per_update} / {own} | {per_pb} |",
            w.frames,
            median_count(&w.particles),
            w.particles.iter().max().copied().unwrap_or(0),
            median_count(&w.beams),
        );
    }
}

/// The median of counts (the lower middle of an even count; 0 when empty).
pub(super) fn median_count(v: &[usize]) -> usize {
    let mut v = v.to_vec();
    v.sort_unstable();
    v.get(v.len().saturating_sub(1) / 2).copied().unwrap_or(0)
}

/// Four significant digits, in scientific notation below 0.001.
pub(super) fn significant(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 { format!("{v:.3e}") } else { format!("{v:.4}") }
}
