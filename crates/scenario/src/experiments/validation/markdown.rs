//! `report.md` of a validation folder: the paper's claims checked, map quality with its
//! intervals, the ground truths, structure retention and change classes, localisation and the
//! updater's work, per world; the files themselves are written by [`super::report`].

use crate::experiments::validation::figures::Figure;
use crate::experiments::validation::{Summary, ValidationRecord};
use crate::stats::{IntervalUnits, MIN_WORLDS_PER_BATCH, WORLD_BATCHES, with_ci};
use std::fmt::Write as _;

/// The paper's published figures the report compares with (Table 1, Table 2 and the §5.3.2
/// claims).
const PAPER_CLAIMS: &str = "\
The paper (Stefanini et al., Sensors 2023) reports for the hundred simulated worlds (§5.3.2,
Fig. 24-26) only plots and these qualitative claims: M_i/G_i is above M_1/G_i for every
metric in every world; localising on M_{i-1} gives lower position errors and lower covariance
trace and λmax than on M_1. Its published tables (real lab and Table 1) give the size of the
effect:

| paper table | CC static → updated | MS static → updated | OPDF static → updated |
|---|---|---|---|
| Table 2, lab W_2 (M_1/G_2 → M_2/G_2) | 69.69 → 78.95 | 54.63 → 74.57 | 84.61 → 97.25 |
| Table 2, lab W_3 | 63.77 → 68.80 | 51.44 → 72.58 | 78.92 → 95.37 |
| Table 2, lab W_4 | 60.87 → 67.14 | 50.45 → 70.26 | 82.18 → 94.33 |
| Table 1, always-update → with localisation check (M_2/G_2) | 66.86 → 70.03 | 55.11 → 61.24 | 90.40 → 95.87 |
";

/// Markdown lines showing the figures of the given stems (SVG shown, PNG linked).
fn figure_lines(s: &mut String, figures: &[Figure], stems: &[&str]) {
    let shown: Vec<&Figure> = figures.iter().filter(|f| stems.contains(&f.stem)).collect();
    if shown.is_empty() {
        return;
    }
    for f in shown {
        let _ = writeln!(
            s,
            "![{paper}: {caption}]({svg})  \n*{paper}: {caption}* ([PNG]({png}))\n",
            paper = f.paper,
            caption = f.caption,
            svg = f.svg_path(),
            png = f.png_path()
        );
    }
}

/// `report.md`: the results beside the paper's claims, without figures.
pub fn report_md(summary: &Summary) -> String {
    report_md_with_figures(summary, &[])
}

/// `report.md`: the results beside the paper's claims, showing `figures` (in `plots/`).
pub fn report_md_with_figures(summary: &Summary, figures: &[Figure]) -> String {
    let mut s = String::new();
    let q = &summary.map_quality;
    let _ = writeln!(s, "# Hundred-world validation: results beside the paper\n");
    let _ = writeln!(
        s,
        "Seeds {:?}, {} worlds, updater preset `{}`, localiser `{}`, {} world runs, {:.0} s simulated, wall time \
         {:.1} s ({}).\n",
        summary.seeds,
        summary.worlds,
        summary.preset,
        summary.localiser,
        summary.rows,
        summary.sim_time_s,
        summary.wall_time_s,
        summary.tool
    );
    pose_source_lines(&mut s, summary);
    let _ = writeln!(s, "## Map quality (Fig. 24)\n");
    let _ = writeln!(
        s,
        "M_1/G_1 (the initial map built by the log-odds mapper against the ground truth of W_1): \
         CC {:.2}, MS {:.2}, OPDF {:.2}.\n",
        summary.initial_map.cc, summary.initial_map.ms, summary.initial_map.opdf
    );
    let _ = writeln!(
        s,
        "| metric | M_1/G_i mean | M_i/G_i mean | M_i − M_1 (95 % CI over {}) | achieved (of M*_i's gain) | M_i − F_i | M_1/G_N | M_N/G_N | worlds with M_i better | paper claim |",
        summary.interval_over()
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    // The ceiling beside each metric: the best achievable map's gain and the fresh map, against
    // the ground truth the table uses (the section below gives both variants).
    let g = match summary.ground_truth.name() {
        "observed" => &summary.by_ground_truth.observed,
        _ => &summary.by_ground_truth.exact,
    };
    let ceiling = [
        (g.best_achievable.cc.achieved_fraction, g.fresh_map.cc),
        (g.best_achievable.ms.achieved_fraction, g.fresh_map.ms),
        (g.best_achievable.opdf.achieved_fraction, g.fresh_map.opdf),
    ];
    for ((name, m), (achieved, fresh)) in
        [("CC (%)", &q.cc), ("MS (%)", &q.ms), ("OPDF (%)", &q.opdf)].into_iter().zip(ceiling)
    {
        let achieved = achieved.map_or("—".to_string(), |a| format!("{:.0} %", 100.0 * a));
        let _ = writeln!(
            s,
            "| {name} | {:.2} | {:.2} | {} | {achieved} | {:+.2} | {:.2} | {:.2} | {:.0} % | updated better in every world |",
            m.static_mean,
            m.updated_mean,
            with_ci(m.diff_mean, m.diff_ci95, 2),
            m.updated_mean - fresh,
            m.static_last,
            m.updated_last,
            100.0 * m.updated_better_fraction
        );
    }
    let _ = writeln!(s, "\n{}\n", summary.interval_note());
    figure_lines(&mut s, figures, &["fig24a_cc", "fig24b_ms", "fig24c_opdf"]);
    ground_truth_section(&mut s, summary);
    erosion_section(&mut s, summary);
    localisation_section(&mut s, summary, figures);
    updater_section(&mut s, summary, figures);
    s.push_str(&crate::results::claims::claims_md(&crate::results::claims::validation_claims(summary)));
    s
}

/// Which pose fed the updater, and its error, when that was not the chain localiser's estimate
/// (`--poses true` or `true+noise`; nothing with the paper's setting, the default).
fn pose_source_lines(s: &mut String, summary: &Summary) {
    let poses = &summary.params.runner.updater_poses;
    if poses.is_localiser() {
        return;
    }
    let _ = write!(
        s,
        "Pose source of the updater: {}. The chain localiser still ran on M_{{i-1}} (its error below is its own; \
         a pose recovered by pose updating re-initialised it as ever), the baseline on M_1; the fresh maps F_i were made \
         at the poses the updater was given.",
        poses.describe()
    );
    if let Some(e) = &summary.updater_pose_error {
        let _ = write!(
            s,
            " Error of the poses the updater was given, over {} steps: RMSE {:.4} m (largest {:.4} m), yaw RMSE \
             {:.3}°.",
            e.steps,
            e.rmse_m,
            e.max_error_m,
            e.yaw_rmse_rad.to_degrees()
        );
    }
    s.push_str("\n\n");
}

/// "every", "every 2nd", "every 3rd", ….
fn every_kth(k: u32) -> String {
    let suffix = match (k % 10, k % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    if k == 1 { "every".into() } else { format!("every {k}{suffix}") }
}

/// Both ground truth variants and the best achievable map.
fn ground_truth_section(s: &mut String, summary: &Summary) {
    let _ = writeln!(
        s,
        "## Ground truth variants and the best achievable map
"
    );
    let _ = writeln!(
        s,
        "The tables and figures above use the `{}` ground truth. `exact`: the raster of all of W_i's geometry \
         over the whole grid (faces no lidar ever sees are occupied; the floor outside the walls counts). \
         `observed`: what noise-free lidars see from the exploration route at true poses in W_i (poses every \
         {} m along it, cast once per world; the paper's G_i were SLAM maps of such a run), unknown elsewhere, \
         scored over the interior of the outer walls. M*_i is the best achievable map: M*_1 = M_1, and M*_i is M*_{{i-1}} with every cell the route observes \
         in W_i set to its state in W_i (a perfect updater on this route). F_i is a fresh map of W_i's run \
         alone (the log-odds mapper of M_1 fed the scans of {} processed step at the chain localiser's \
         estimates, no prior; M_1 took {} step of its exploration run): what remapping every time instead of \
         updating would give. Achieved = (M_i − M_1) / (M*_i − M_1) on the means: the share of the \
         achievable improvement M_i reaches. The log-odds chain is the \
         `log-odds` preset (`--presets paper,mapkeeper,log-odds` puts it beside).\n",
        summary.ground_truth.name(),
        mapkeeper_closed_loop::worlds::observed::OBSERVATION_STEP_M,
        summary.params.runner.fresh_map.as_ref().map_or("every".into(), |f| every_kth(f.scan_stride)),
        every_kth(summary.params.mapping.scan_stride),
    );
    let _ = writeln!(
        s,
        "| ground truth | metric | M_1/G_i | M_i/G_i | M*_i/G_i | F_i/G_i | M_i − M_1 (95 % CI) | achieved |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    let b = &summary.by_ground_truth;
    for (gt, g) in [("exact", &b.exact), ("observed", &b.observed)] {
        let q = &g.map_quality;
        let best = &g.best_achievable;
        let f = &g.fresh_map;
        for (name, m, x, fresh) in
            [("CC", &q.cc, &best.cc, f.cc), ("MS", &q.ms, &best.ms, f.ms), ("OPDF", &q.opdf, &best.opdf, f.opdf)]
        {
            let achieved = x.achieved_fraction.map_or("—".to_string(), |a| format!("{:.0} %", 100.0 * a));
            let _ = writeln!(
                s,
                "| {gt} | {name} | {:.2} | {:.2} | {:.2} | {fresh:.2} | {} | {achieved} |",
                m.static_mean,
                m.updated_mean,
                x.best_mean,
                with_ci(m.diff_mean, m.diff_ci95, 2)
            );
        }
    }
    let _ = writeln!(s);
}

/// A percentage with two decimals, or a dash for none.
fn pct_or_dash(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_owned(), |v| format!("{v:.2}"))
}

/// Structure retention and the change classes (against the exact G_i).
fn erosion_section(s: &mut String, summary: &Summary) {
    let _ = writeln!(
        s,
        "## Structure retention and change classes
"
    );
    let (Some(r), Some(c)) = (&summary.retention, &summary.change_classes) else {
        let _ = writeln!(s, "Not in these records (written before structure retention was measured).\n");
        return;
    };
    let _ = writeln!(
        s,
        "Against the exact G_i, whatever the ground truth above (`docs/metrics.md`). **Structure retention**: of \
         the cells occupied in M_1 and in every G_1 … G_i (S_i, the fixed structure M_1 got right: {:.0} cells on \
         average), the share a map still has occupied; M_1 keeps 100 % by definition. **Change classes**: the \
         cells the route observes in W_i where M_1 and G_i disagree (one free, the other occupied), by what \
         explains them: *added* (free → occupied on an item put down since W_1), *removed* (occupied → free where \
         an item taken away stood), *moved* (either, on an item moved or turned since W_1; within a cell of its \
         footprints) and *initial errors* (no edit explains them: M_1's own disagreements with the exact \
         raster); the share a map has in G_i's state. M*_i has 100 % of both by construction. Means over world \
         rows (class shares over the rows where the class has cells){}.\n",
        r.structure_cells_mean,
        if r.rows < summary.rows {
            format!("; {} of the {} world rows have the figures (older records have none)", r.rows, summary.rows)
        } else {
            String::new()
        }
    );
    let _ = writeln!(s, "| figure (%) | M_i | M*_i | F_i | M_2 at W_2 | M_N at W_N |");
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    let _ = writeln!(
        s,
        "| structure retention | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} (lowest seed {:.2}) |",
        r.updated_mean, r.best_mean, r.fresh_mean, r.updated_w2, r.updated_last, r.updated_last_min
    );
    for (name, k) in
        [("added", &c.added), ("removed", &c.removed), ("moved", &c.moved), ("initial-error", &c.initial_errors)]
    {
        let _ = writeln!(
            s,
            "| {name} cells right ({:.1} per world; in {} worlds) | {} | {} | {} | — | {} |",
            k.cells_mean,
            k.rows,
            pct_or_dash(k.updated_mean),
            pct_or_dash(k.best_mean),
            pct_or_dash(k.fresh_mean),
            pct_or_dash(k.updated_last)
        );
    }
    let _ = writeln!(
        s,
        "\nTarget (the project's; the paper states none): retention of M_N ≥ {:.0} %: **{}** ({:.2} %).\n",
        r.target_last,
        if r.target_met { "met" } else { "not met" },
        r.updated_last
    );
}

fn localisation_section(s: &mut String, summary: &Summary, figures: &[Figure]) {
    let l = &summary.localisation;
    let _ = writeln!(s, "## Localisation (Fig. 25-26)\n");
    let _ = writeln!(
        s,
        "| map used by the localiser | mean error (m) | mean max error (m) | largest error (m) | RMSE (m) | mean trace(P) | mean λmax(P) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for (name, v) in [("static M_1", &l.static_map), ("updated M_{i-1}", &l.updated_map)] {
        let _ = writeln!(
            s,
            "| {name} | {:.4} | {:.4} | {:.4} | {:.4} | {:.6} | {:.6} |",
            v.mean_error_m, v.mean_max_error_m, v.max_error_m, v.rmse_m, v.mean_trace, v.mean_lambda_max
        );
    }
    let f = &summary.params.runner.filter;
    let _ = writeln!(
        s,
        "\nBoth localisers (`{}`) are given every frame of the drive, the baseline on M_1 and the chain on \
         M_{{i-1}}; each runs its sensor update when its own gate opens (after {} m or {:.2} rad of travel).",
        summary.localiser, f.update_min_d_m, f.update_min_a_rad
    );
    let _ = writeln!(
        s,
        "\nWorlds where the updated map gave the lower mean error: {:.0} %; the lower mean covariance trace: {:.0} % \
         (paper: lower errors and lower uncertainty with the updated map). Chain − baseline mean error (each \
         seed's mean over its worlds, averaged over {} seed(s), 95 % interval over {}): {} m.\n",
        100.0 * l.updated_better_fraction,
        100.0 * l.updated_lower_trace_fraction,
        summary.seeds.len(),
        summary.interval_over(),
        with_ci(l.error_diff_mean_m, l.error_diff_ci95_m, 4)
    );
    figure_lines(
        s,
        figures,
        &["fig25a_position_error", "fig25b_max_position_error", "fig26a_trace", "fig26b_lambda_max"],
    );
}

fn updater_section(s: &mut String, summary: &Summary, figures: &[Figure]) {
    let u = &summary.updater;
    let _ = writeln!(s, "## Updater (Fig. 27)\n");
    let _ = writeln!(
        s,
        "Processed scans {}, verdicts Update {} / Suspend {} / Lost {} (recovered {}), cell changes {}, largest \
         change state {} bytes (map-sized caches: {} bytes), median time per processed scan {:.0} µs (0 = not measured). Robot collisions: {}. Routes \
         completed: {} of {}.\n",
        u.processed_scans,
        u.update,
        u.suspend,
        u.lost,
        u.recovered,
        u.cell_changes,
        u.max_state_bytes,
        u.max_cache_bytes,
        u.median_scan_us,
        summary.collisions,
        summary.routes_completed,
        summary.rows
    );
    let l = &summary.lost_handling;
    let _ = writeln!(
        s,
        "Lost handling (the robot stops on Lost until pose updating returns a pose, a processed step says \
         Update or Suspend, or {:.1} s pass): {} episodes, {} attempts of pose updating, {} ended by a recovered \
         pose, {} by Update/Suspend, {} given up; robot stopped {:.1} s in all.\n",
        summary.params.runner.lost_wait_s,
        l.episodes,
        l.attempts,
        l.recoveries,
        l.cleared,
        l.give_ups,
        l.stopped_s()
    );
    if let Some(h) = &summary.heavy_change {
        let _ = writeln!(
            s,
            "Heavy change (the map updated only in every {}-th world, {} worlds of change at once): over the {} \
             updated worlds, {:.2} % of the processed steps said Suspend and {:.2} % Lost while the chain localiser's \
             mean error was {:.3} m; {} of them were stuck (fewer than half the steps said Update), at most {} in a \
             row; {:.0} cells changed per updated world.\n",
            h.update_every,
            h.update_every,
            h.update_worlds,
            100.0 * h.suspend_share,
            100.0 * h.lost_share,
            h.mean_error_m,
            h.stuck_worlds,
            h.longest_stuck_run,
            h.mean_cells_changed
        );
    }
    figure_lines(s, figures, &["fig27a_updater_time", "fig27b_updater_memory"]);
    let _ = writeln!(s, "## The paper's figures\n");
    s.push_str(PAPER_CLAIMS);
    let _ = writeln!(
        s,
        "\nDifferences of setting: the paper's M_1 and G_i came from SLAM Toolbox; here M_1 comes from the \
         project's log-odds mapper at true poses and G_i is rasterised exactly from the world's geometry (cells \
         inside obstacles unknown, as in the paper's Fig. 23). See `docs/evaluation.md`."
    );
}

/// The paper's Table 2 (the lab, §5.5): per world i = 2, 3, 4, CC, MS and OPDF (%) of M_1/G_i
/// and M_i/G_i.
pub const PAPER_TABLE2: [(usize, [f64; 3], [f64; 3]); 3] = [
    (2, [69.69, 54.63, 84.61], [78.95, 74.57, 97.25]),
    (3, [63.77, 51.44, 78.92], [68.80, 72.58, 95.37]),
    (4, [60.87, 50.45, 82.18], [67.14, 70.26, 94.33]),
];

/// Reads one score out of a map's scores.
type ScoreOf<'a> = &'a dyn Fn(&crate::experiments::validation::Scores) -> f64;

/// For a short chain (at most 10 worlds): a table per world of M_1/G_i and M_i/G_i, means over
/// the seeds, in the layout of the paper's Table 2; in the lab (`--world lab`), the paper's
/// Table 2 beside it. Empty for longer chains.
pub fn per_world_md(record: &ValidationRecord) -> String {
    let worlds = record.params.worlds;
    if worlds > 10 || record.seeds.is_empty() {
        return String::new();
    }
    let lab = record.params.world.as_deref() == Some("lab");
    let mut s = format!(
        "\n## Per world (the layout of the paper's Table 2)\n\nMeans over {} seed(s) of M_1/G_i and M_i/G_i, %{}.\n\n",
        record.seeds.len(),
        if lab { "; the paper's Table 2 (its real lab, one run) in the columns headed *paper*" } else { "" }
    );
    s.push_str("| world | metric | M_1/G_i | M_i/G_i | M_i − M_1 |");
    if lab {
        s.push_str(" paper M_1/G_i | paper M_i/G_i | paper M_i − M_1 |");
    }
    s.push('\n');
    s.push_str(if lab { "|---|---|---|---|---|---|---|---|\n" } else { "|---|---|---|---|---|\n" });
    for i in 2..=worlds {
        let rows: Vec<&crate::experiments::validation::WorldRow> =
            record.seeds.iter().flat_map(|r| r.rows.iter().filter(move |w| w.world == i)).collect();
        if rows.is_empty() {
            continue;
        }
        let pick = |f: ScoreOf<'_>, updated: bool| {
            crate::stats::mean(rows.iter().map(|w| f(if updated { &w.updated_map } else { &w.static_map })))
        };
        let metrics: [(&str, ScoreOf<'_>); 3] = [("CC", &|x| x.cc), ("MS", &|x| x.ms), ("OPDF", &|x| x.opdf)];
        for (k, (name, f)) in metrics.iter().enumerate() {
            let (a, b) = (pick(*f, false), pick(*f, true));
            let _ = write!(s, "| W_{i} | {name} | {a:.2} | {b:.2} | {:+.2} |", b - a);
            if lab {
                match PAPER_TABLE2.iter().find(|(w, _, _)| *w == i) {
                    Some((_, st, up)) => {
                        let _ = write!(s, " {:.2} | {:.2} | {:+.2} |", st[k], up[k], up[k] - st[k]);
                    }
                    None => s.push_str(" – | – | – |"),
                }
            }
            s.push('\n');
        }
    }
    s
}

impl Summary {
    /// What the intervals are over, in a few words: "3 seeds", "10 batches of seed 11's worlds".
    pub fn interval_over(&self) -> String {
        match (self.interval_units, self.seeds.as_slice()) {
            (IntervalUnits::WorldBatches, [seed]) => format!("{WORLD_BATCHES} batches of seed {seed}'s worlds"),
            (_, [_]) => "1 seed: none".to_owned(),
            (_, seeds) => format!("{} seeds", seeds.len()),
        }
    }

    /// The paragraph under the map-quality table: how M_i − M_1 and its interval are formed.
    pub fn interval_note(&self) -> String {
        let head = "M_i − M_1: each seed's mean over its worlds of M_i/G_i − M_1/G_i, averaged over the seeds; the \
                    interval is the 95 % Student-t interval";
        match (self.interval_units, self.seeds.len()) {
            (IntervalUnits::WorldBatches, _) => format!(
                "{head} of the batch means: the one seed's worlds cut into {WORLD_BATCHES} runs of consecutive worlds, \
                 each run's mean one unit (the worlds are not independent: each map is made from the previous one; \
                 neighbouring batches are less so, not independent, which narrows the interval somewhat). It says how precisely this seed's chain of worlds pins its mean, not \
                 how much another seed's chain would differ: run with --seeds 3 or more for the interval over seeds \
                 (docs/evaluation.md, \"Intervals\")."
            ),
            (_, n) if n >= 2 => format!(
                "{head}, paired, with the seeds as units (the worlds of one seed are not independent: each map is made from \
                 the previous one)."
            ),
            _ => format!(
                "{head}; with one seed of fewer than {} updated worlds (W_2 … W_N) there is none (run with --seeds 3 \
                 or more, or --worlds {} or more).",
                WORLD_BATCHES * MIN_WORLDS_PER_BATCH,
                WORLD_BATCHES * MIN_WORLDS_PER_BATCH + 1
            ),
        }
    }

    /// The summary table printed by `validate` and `merge`.
    pub fn table(&self) -> String {
        let mut t = String::new();
        let (q, l, u) = (&self.map_quality, &self.localisation, &self.updater);
        let m1 = &self.initial_map;
        let _ = writeln!(t, "M_1/G_1: CC {:.2}  MS {:.2}  OPDF {:.2}", m1.cc, m1.ms, m1.opdf);
        let _ = writeln!(
            t,
            "{:<10} {:>10} {:>10} {:>12}  M_i − M_1, 95 % CI over {}",
            "metric",
            "M_1/G_i",
            "M_i/G_i",
            "M_i better",
            self.interval_over()
        );
        for (name, m) in [("CC %", &q.cc), ("MS %", &q.ms), ("OPDF %", &q.opdf)] {
            let better = 100.0 * m.updated_better_fraction;
            let diff = with_ci(m.diff_mean, m.diff_ci95, 2);
            let _ = writeln!(t, "{name:<10} {:>10.2} {:>10.2} {better:>11.0}%  {diff}", m.static_mean, m.updated_mean);
        }
        let _ = writeln!(t, "{:<10} {:>10} {:>10} {:>12}", "localiser", "mean err m", "max err m", "mean trace");
        for (name, v) in [("on M_1", &l.static_map), ("on M_i-1", &l.updated_map)] {
            let _ = writeln!(t, "{name:<10} {:>10.4} {:>10.4} {:>12.6}", v.mean_error_m, v.max_error_m, v.mean_trace);
        }
        let _ = writeln!(
            t,
            "updater: {} scans, Update {} Suspend {} Lost {}, median {:.0} us/scan, state ≤ {} B; collisions {}; routes done {}/{}",
            u.processed_scans,
            u.update,
            u.suspend,
            u.lost,
            u.median_scan_us,
            u.max_state_bytes,
            self.collisions,
            self.routes_completed,
            self.rows
        );
        if let Some(line) = registration_line(&u.registration, u.heal_votes) {
            let _ = writeln!(t, "{line}");
        }
        if let (Some(r), Some(c)) = (&self.retention, &self.change_classes) {
            let _ = writeln!(
                t,
                "retention of M_i: W_2 {:.2} %, W_N {:.2} % (target ≥ {:.0} %: {}), mean {:.2} %; M_i right: added {}, \
                 removed {}, moved {}, initial errors {} %",
                r.updated_w2,
                r.updated_last,
                r.target_last,
                if r.target_met { "met" } else { "not met" },
                r.updated_mean,
                pct_or_dash(c.added.updated_mean),
                pct_or_dash(c.removed.updated_mean),
                pct_or_dash(c.moved.updated_mean),
                pct_or_dash(c.initial_errors.updated_mean)
            );
        }
        let _ = writeln!(t, "lost handling: {}", self.lost_handling);
        if let Some(e) = &self.updater_pose_error {
            let _ = writeln!(
                t,
                "updater poses: {} (error RMSE {:.4} m, largest {:.4} m, yaw RMSE {:.3}° over {} steps)",
                self.params.runner.updater_poses.name(),
                e.rmse_m,
                e.max_error_m,
                e.yaw_rmse_rad.to_degrees(),
                e.steps
            );
        }
        t
    }
}

/// One line on registration before writing and the memory's healing votes; `None` when
/// registration never ran.
pub fn registration_line(r: &mapkeeper_updater::RegistrationStats, heal_votes: u64) -> Option<String> {
    let tried = r.accepted + r.refused_total();
    if tried == 0 {
        return None;
    }
    let share = |n: u64| 100.0 * n as f64 / tried as f64;
    let (shift_cm, turn_deg) = if r.accepted > 0 {
        (
            r.shift_sum_um as f64 / r.accepted as f64 / 1e4,
            (r.turn_sum_urad as f64 / r.accepted as f64 / 1e6).to_degrees(),
        )
    } else {
        (0.0, 0.0)
    };
    Some(format!(
        "registration: {} of {tried} steps refined ({:.1} %), refused: few points {}, poor fit {}, degenerate {}, too far {}; \
         writes withheld {}; mean correction {shift_cm:.2} cm, {turn_deg:.3}°; |Δxy| per bin (<0.5/1/2/5/10/20 cm/more) {:?}; \
         |Δyaw| per bin (<0.05/0.1/0.25/0.5/1/2°/more) {:?}; memory heal votes {heal_votes}",
        r.accepted,
        share(r.accepted),
        r.refused_too_few_points,
        r.refused_poor_fit,
        r.refused_degenerate,
        r.refused_too_far,
        r.writes_withheld,
        r.shift_histogram,
        r.turn_histogram,
    ))
}
