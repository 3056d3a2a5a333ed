//! `mapkeeper validate`: the hundred-world validation of the paper (§5.3.2), over one or more
//! seeds in parallel; the wall clock is read here (not in the libraries).

use anyhow::{Context, bail};
use mapkeeper_scenario::report::write_validation;
use mapkeeper_scenario::{NoClock, SeedRun, Shard, StagedDir, ValidationParams, ValidationRecord, run_seed};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `mapkeeper validate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "For each seed: generate W_1 … W_N; build M_1 in W_1 with the log-odds mapper; in each \
W_i (i ≥ 2) drive the route with a chain localiser on M_{i-1} (feeding the updater, which makes M_i) and a \
baseline localiser on M_1; score M_1/G_i and M_i/G_i with CC, MS, OPDF.\n\n\
Output in OUT (default results/validate-s<SEED>-<N>w-<counter>): runs.json, summary.json, worlds.csv, \
report.md, edits.json, plots/ (Fig. 24-27, SVG and PNG), seed-S/maps (M_i, G_i of W_1, W_2, W_50, W_100, \
W_N), seed-S/trajectories (TUM: true, chain, baseline). Results are identical whatever --jobs; only \
wall_time_s and median_scan_us vary (not with --no-timing).\n\n\
Sharding: --shard k/N runs the k-th of N contiguous slices of the seeds; `mapkeeper merge` combines the \
shards' folders into the folder of the whole run.\n\n\
Sweeps over presets: --presets a,b,… makes the job list (preset × seed), preset by preset; each preset's \
results go to OUT/<preset>/ (a folder as above), and --shard slices that job list. Merge the shards \
preset by preset: mapkeeper merge s1/paper s2/paper --out all/paper.")]
pub struct Args {
    /// Number of worlds N.
    #[arg(long, default_value_t = 100)]
    pub worlds: usize,
    /// First run seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of seeds (seed, seed+1, …), run in parallel.
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
    /// Updater preset: paper, reference, always-update, no-update, log-odds.
    #[arg(long, default_value = "paper")]
    pub preset: String,
    /// A sweep over several presets (comma-separated, e.g. paper,always-update): jobs are
    /// (preset × seed); each preset's results go to OUT/<preset>/.
    #[arg(long, value_name = "P1,P2,…", conflicts_with = "preset", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
    /// Drive only the first this-many metres of the route (quick checks).
    #[arg(long, value_name = "METRES")]
    pub route_length: Option<f64>,
    /// Do not time the updater (all timing fields 0: outputs bit-identical between runs).
    #[arg(long)]
    pub no_timing: bool,
    /// Run only the k-th of N slices of the seeds (1 ≤ k ≤ N ≤ --seeds); merge the shards'
    /// folders with `mapkeeper merge`.
    #[arg(long, value_name = "k/N", value_parser = parse_shard)]
    pub shard: Option<Shard>,
}

/// Parses `k/N` with 1 ≤ k ≤ N.
fn parse_shard(s: &str) -> Result<Shard, String> {
    let bad = || format!("expected k/N with 1 ≤ k ≤ N (e.g. 2/4), got '{s}'");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let index: u64 = k.trim().parse().map_err(|_| bad())?;
    let count: u64 = n.trim().parse().map_err(|_| bad())?;
    if index == 0 || count == 0 || index > count {
        return Err(bad());
    }
    Ok(Shard { index, count })
}

fn default_out(seed: u64, worlds: usize, shard: Option<Shard>) -> PathBuf {
    let part = shard.map(|s| format!("-shard{}of{}", s.index, s.count)).unwrap_or_default();
    let mut k = 1;
    loop {
        let p = PathBuf::from(format!("results/validate-s{seed}-{worlds}w{part}-{k:03}"));
        if !p.exists() {
            return p;
        }
        k += 1;
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    let sweep = args.presets.is_some();
    let presets: Vec<String> = args.presets.clone().unwrap_or_else(|| vec![args.preset.clone()]);
    if presets.is_empty() || presets.iter().any(|p| p.trim().is_empty()) {
        bail!("--presets needs preset names separated by commas");
    }
    if let Some((i, p)) = presets.iter().enumerate().find(|(i, p)| presets[..*i].contains(p)) {
        bail!("--presets names '{p}' twice (entry {})", i + 1);
    }
    let mut params_of = Vec::with_capacity(presets.len());
    for preset in &presets {
        let mut params =
            ValidationParams::new(args.worlds, preset).with_context(|| format!("--preset(s): '{preset}'"))?;
        if let Some(len) = args.route_length {
            if !(len.is_finite() && len > 0.0) {
                bail!("--route-length must be a positive number of metres, got {len}");
            }
            params.route = ValidationParams::short_route(len);
        }
        params_of.push(params);
    }
    let all_seeds: Vec<u64> = (0..args.seeds).map(|k| args.seed.saturating_add(k)).collect();
    if all_seeds.windows(2).any(|w| w[0] == w[1]) {
        bail!("--seed {} with --seeds {} runs past the largest seed", args.seed, args.seeds);
    }
    // The job list: (preset index, seed), preset by preset.
    let all_jobs: Vec<(usize, u64)> = (0..presets.len()).flat_map(|p| all_seeds.iter().map(move |&s| (p, s))).collect();
    let jobs: Vec<(usize, u64)> = match args.shard {
        None => all_jobs,
        Some(sh) => match sh.slice(&all_jobs) {
            Some(s) => s.to_vec(),
            None => bail!(
                "--shard {}/{}: {} job(s) ({} preset(s) × {} seed(s)) cannot make {} non-empty shards",
                sh.index,
                sh.count,
                all_jobs.len(),
                presets.len(),
                args.seeds,
                sh.count
            ),
        },
    };
    let out = args.out.clone().unwrap_or_else(|| default_out(args.seed, args.worlds, args.shard));
    // Validate the output folders before running anything.
    let groups: Vec<usize> = (0..presets.len()).filter(|&p| jobs.iter().any(|j| j.0 == p)).collect();
    let mut dirs = Vec::with_capacity(groups.len());
    if sweep {
        if out.is_file() {
            bail!("{}: exists and is not a folder", out.display());
        }
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
        for &p in &groups {
            dirs.push(StagedDir::create(&out.join(&presets[p]), args.force)?);
        }
    } else {
        dirs.push(StagedDir::create(&out, args.force)?);
    }
    let total = jobs.len() as u64 * args.worlds as u64;
    let bar = super::progress_bar(total, "worlds");
    let pool = super::thread_pool(args.jobs)?;
    let start = Instant::now();
    let wall = super::Wall::start();
    let runs: Vec<SeedRun> = pool.install(|| {
        jobs.par_iter()
            .map(|&(p, s)| {
                let progress = |_: usize| bar.inc(1);
                if args.no_timing {
                    run_seed(&params_of[p], s, &NoClock, &progress)
                } else {
                    run_seed(&params_of[p], s, &wall, &progress)
                }
            })
            .collect::<Result<Vec<_>, _>>()
    })?;
    bar.finish_and_clear();
    let wall_time_s = start.elapsed().as_secs_f64();
    let timing = !args.no_timing;
    for (&p, dir) in groups.iter().zip(dirs) {
        let group: Vec<SeedRun> = jobs.iter().zip(&runs).filter(|(j, _)| j.0 == p).map(|(_, r)| r.clone()).collect();
        let seeds: Vec<u64> = group.iter().map(|r| r.seed).collect();
        let record =
            ValidationRecord::new(&params_of[p], &group, timing, if timing { wall_time_s } else { 0.0 }, args.shard);
        let summary = write_validation(&dir, &group, &record)?;
        let written = dir.finish()?;
        let shard =
            args.shard.map(|s| format!(" (shard {}/{}: seeds {:?})", s.index, s.count, seeds)).unwrap_or_default();
        println!(
            "validate: {} seed(s) × {} worlds, preset {}, {:.1} s wall{shard}",
            seeds.len(),
            args.worlds,
            presets[p],
            wall_time_s
        );
        print_summary(&summary);
        println!("wrote {}", written.display());
    }
    Ok(())
}

/// The summary table printed by `validate` and `merge`.
pub fn print_summary(summary: &mapkeeper_scenario::Summary) {
    let q = &summary.map_quality;
    let l = &summary.localisation;
    println!(
        "M_1/G_1: CC {:.2}  MS {:.2}  OPDF {:.2}",
        summary.initial_map.cc, summary.initial_map.ms, summary.initial_map.opdf
    );
    println!("{:<10} {:>10} {:>10} {:>12}", "metric", "M_1/G_i", "M_i/G_i", "M_i better");
    for (name, m) in [("CC %", &q.cc), ("MS %", &q.ms), ("OPDF %", &q.opdf)] {
        println!(
            "{name:<10} {:>10.2} {:>10.2} {:>11.0}%",
            m.static_mean,
            m.updated_mean,
            100.0 * m.updated_better_fraction
        );
    }
    println!("{:<10} {:>10} {:>10} {:>12}", "localiser", "mean err m", "max err m", "mean trace");
    for (name, v) in [("on M_1", &l.static_map), ("on M_i-1", &l.updated_map)] {
        println!("{name:<10} {:>10.4} {:>10.4} {:>12.6}", v.mean_error_m, v.max_error_m, v.mean_trace);
    }
    let u = &summary.updater;
    println!(
        "updater: {} scans, Update {} Suspend {} Lost {}, median {:.0} us/scan, state ≤ {} B; collisions {}; routes done {}/{}",
        u.processed_scans,
        u.update,
        u.suspend,
        u.lost,
        u.median_scan_us,
        u.max_state_bytes,
        summary.collisions,
        summary.routes_completed,
        summary.rows
    );
}
