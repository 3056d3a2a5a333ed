//! The outputs of `mapkeeper experiment sensor-realism`: `summary.json` (parameters, one
//! summary per configuration), `worlds.csv` (every world run) and `report.md` (the table of
//! each switch's effect).

use crate::experiments::validation::sensor_realism::{RealismRow, SensorRealismResult};
use crate::results::ResultsError;
use crate::stats::with_ci;
use mapkeeper_grid::StagedDir;
use std::fmt::Write as _;

/// Writes the three files into `dir`. `header` (the command, the world, the localiser) heads
/// the report.
pub fn write_sensor_realism(dir: &StagedDir, r: &SensorRealismResult, header: &str) -> Result<(), ResultsError> {
    #[derive(serde::Serialize)]
    struct Summary<'a> {
        format: &'static str,
        params: &'a crate::experiments::validation::sensor_realism::SensorRealismParams,
        configs: &'a [crate::experiments::validation::sensor_realism::ConfigSummary],
    }
    let s = Summary { format: "mapkeeper-sensor-realism", params: &r.params, configs: &r.summaries };
    let json = serde_json::to_string_pretty(&s)
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    dir.write("worlds.csv", worlds_csv(&r.rows).as_bytes())?;
    dir.write("report.md", report_md(r, header).as_bytes())?;
    Ok(())
}

fn worlds_csv(rows: &[RealismRow]) -> String {
    let mut s = String::from(
        "config,seed,world,cc_static,cc_updated,ms_updated,opdf_updated,err_mean_m,err_max_m,lost_episodes,collisions,route_done\n",
    );
    for r in rows {
        let w = &r.row;
        let _ = writeln!(
            s,
            "{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{}",
            r.config,
            w.seed,
            w.world,
            w.cc_static,
            w.cc_updated,
            w.ms_updated,
            w.opdf_updated,
            w.err_mean_m,
            w.err_max_m,
            w.lost_episodes,
            w.collisions,
            w.route_done
        );
    }
    s
}

/// The report: one row per configuration.
pub fn report_md(r: &SensorRealismResult, header: &str) -> String {
    let p = &r.params;
    let mut s = String::from("# Sensor realism: the effect of each switch\n\n");
    let _ = writeln!(
        s,
        "{header}\n\nPreset `{}`, W_1 … W_{} of seeds {} … {}, the first {} m of the route in each world. \
         Each configuration runs the same seeds; Δ is the configuration minus `ideal`, per seed (mean over \
         its worlds), with its 95 % interval over the seeds. Definitions: docs/simulator.md (the switches), \
         docs/metrics.md (the scores).\n",
        p.preset,
        p.worlds,
        p.first_seed,
        p.first_seed + p.seeds as u64 - 1,
        p.route_length_m
    );
    s.push_str(
        "| configuration | CC M_i % | Δ CC vs ideal | MS M_i % | OPDF M_i % | CC M_1 % | mean err m | Δ err vs ideal m | max err m | Lost | collisions | routes done |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for c in &r.summaries {
        let _ = writeln!(
            s,
            "| {} | {:.2} | {} | {:.2} | {:.2} | {:.2} | {:.4} | {} | {:.3} | {} | {} | {}/{} |",
            c.config,
            c.cc_updated_mean,
            if c.config == "ideal" {
                "—".into()
            } else {
                with_ci(c.cc_updated_vs_ideal.mean, c.cc_updated_vs_ideal.ci95, 2)
            },
            c.ms_updated_mean,
            c.opdf_updated_mean,
            c.cc_static_mean,
            c.err_mean_m,
            if c.config == "ideal" {
                "—".into()
            } else {
                with_ci(c.err_mean_vs_ideal_m.mean, c.err_mean_vs_ideal_m.ci95, 4)
            },
            c.err_max_m,
            c.lost_episodes,
            c.collisions,
            c.routes_done,
            c.runs
        );
    }
    s
}
