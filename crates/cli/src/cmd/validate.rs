//! `mapkeeper validate`: the hundred-world validation of the paper (§5.3.2), over one or more
//! seeds in parallel; the wall clock is read here (not in the libraries).

use super::sweep_progress::{SweepProgress, describe};
use anyhow::Context;
use mapkeeper_scenario::experiments::checkpoint::Checkpoints;
use mapkeeper_scenario::results::comparison::{Comparison, write_comparison};
use mapkeeper_scenario::results::report::write_validation;
use mapkeeper_scenario::{Clock, GroundTruth, NoClock, Shard, StagedDir, SweepPlan, SweepSpec, ValidationRecord};
use mapkeeper_updater::UpdaterParams;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `mapkeeper validate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Default: the paper's setting over three hold-out seeds: presets paper and \
mapkeeper side by side (a sweep, below), the amcl localiser, seeds 11, 12, 13, a hundred worlds each \
(72 min measured on two cores shared with a CI run). --preset P runs one preset into OUT itself.\n\n\
For each seed: generate W_1 … W_N; build M_1 in W_1 with the log-odds mapper; in each \
W_i (i ≥ 2) drive the route with a chain localiser on M_{i-1} (feeding the updater, which makes M_i; \
--poses true or true+noise feeds it the true pose instead, with or without noise) and a baseline localiser on M_1; score M_1/G_i and M_i/G_i with CC, MS, OPDF.\n\n\
Output in OUT (default results/validate-s<SEED>-<N>w-<counter>): runs.json, summary.json, worlds.csv, \
report.md, report.html (the report as one self-contained page, with a world stepper), edits.json, plots/ \
(Fig. 24-27, SVG and PNG), seed-S/maps (M_i, G_i and E_i, the errors of M_i against G_i as a PNG, of W_1 and \
the saved worlds: W_2, W_50, W_100, W_N, or --save-maps), seed-S/trajectories (TUM: true, chain, baseline). Results are identical whatever --jobs; only \
wall_time_s and median_scan_us vary (not with --no-timing).\n\n\
Sharding: --shard k/N runs the k-th of N contiguous slices of the seeds; `mapkeeper merge` combines the \
shards' folders into the folder of the whole run.\n\n\
Sweeps over presets: --presets a,b,… makes the job list (preset × seed), preset by preset; each preset's \
results go to OUT/<preset>/ (a folder as above), and --shard slices that job list. OUT/summary.json and \
OUT/report.md compare the presets side by side: one row per preset (and per preset and seed with several \
seeds) with the map-quality means (M_1/G_i, M_i/G_i, M_N/G_N), the share of worlds where M_i beats M_1, the \
localisation error means on M_1 and M_{i-1}, the verdict counts and the Lost handling (episodes, attempts, \
recoveries, give-ups, time stopped). Merge sharded sweeps whole (mapkeeper merge s1 s2 s3 --out all: preset \
by preset, then the comparison) or preset by preset (mapkeeper merge s1/paper s2/paper --out all/paper).")]
pub struct Args {
    /// Number of worlds N, 2 to 10000 (100 × the paper's hundred worlds: many hours per seed).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = super::count_in(2, super::MAX_WORLDS), allow_hyphen_values = true)]
    pub worlds: usize,
    /// First run seed (any whole number from 0 to 2^64 − 1). The default, 11, is the first
    /// hold-out seed: seeds 1-3 tuned the `mapkeeper` preset and are never the reported ones.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SEED, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Number of seeds (seed, seed+1, …), run in parallel; 1 to 100000 (each seed is a whole
    /// validation; 2 or more give the paired 95 % intervals of the differences, 3 or more
    /// intervals of a useful width: t(0.975, 1) = 12.7).
    #[arg(long, value_name = "K", default_value_t = 3, value_parser = super::count_in(1, super::MAX_SEEDS), allow_hyphen_values = true)]
    pub seeds: usize,
    /// One updater preset: paper, paper-strict, authors, mapkeeper, mapkeeper-no-registration, mapkeeper-shift,
    /// always-update, no-update, log-odds (results
    /// in OUT itself). Without --preset or --presets: the sweep paper,mapkeeper.
    #[arg(long)]
    pub preset: Option<String>,
    /// TOML file overriding any field of the updater preset(s) (unknown keys are errors), e.g.
    /// `removal_hit_clearance_m = 0.1`; recorded in summary.json with the preset's name.
    #[arg(long, value_name = "FILE")]
    pub updater_params: Option<PathBuf>,
    /// A sweep over several presets (comma-separated, e.g. paper,always-update): jobs are
    /// (preset × seed); each preset's results go to `OUT/<preset>/` [default: paper,mapkeeper].
    #[arg(long, value_name = "P1,P2,…", conflicts_with = "preset", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// Localiser preset of the chain and baseline localisers: mapkeeper, mapkeeper-real, amcl or amcl-joint
    /// (docs/localiser.md); recorded in summary.json and report.md. The default, amcl, is the
    /// filter the paper ran.
    #[arg(long, value_name = "NAME", default_value = "amcl")]
    pub localiser: String,
    /// Ground truth of the map metrics: `exact` (the raster of all geometry, whole grid) or
    /// `observed` (what a noise-free mapper sees from the exploration route in W_i, over the
    /// interior of the outer walls; the paper's G_i were such SLAM maps). The other variant and
    /// the best achievable map are reported beside it.
    #[arg(long, value_name = "exact|observed", default_value = "exact", value_parser = str::parse::<GroundTruth>)]
    pub ground_truth: GroundTruth,
    /// The world W_1: an embedded world, `warehouse` (the default) or `lab` (the paper's
    /// lab, §5.5), or a world file (docs/world-format.md). Its storage areas and route come
    /// from the file, or are derived and planned when it has none; the resolved world is
    /// written as OUT/world.toml.
    #[arg(long, value_name = "NAME|FILE")]
    pub world: Option<PathBuf>,
    /// Route file (docs/world-format.md) overriding the world's route.
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Worker threads, 1 to 1024 (default: all cores; more threads than runs gain nothing).
    #[arg(long, value_name = "N", value_parser = super::jobs, allow_hyphen_values = true)]
    pub jobs: Option<usize>,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
    /// Resume a killed run (needs --out): every finished (preset, seed) job is kept in
    /// `.NAME.jobs/` beside OUT until the run completes; with --resume those jobs are read back
    /// rather than run again (the outputs are the same), and an OUT already complete is left as
    /// it is. Without --resume a new run discards them.
    #[arg(long, requires = "out", conflicts_with = "force")]
    pub resume: bool,
    /// Drive only the first this-many metres of the route (quick checks); > 0 and ≤ 10000 m
    /// (the default tour is 72 m: longer values drive all of it).
    #[arg(long, value_name = "METRES", value_parser = super::route_length, allow_hyphen_values = true)]
    pub route_length: Option<f64>,
    /// Update the map only in every k-th world (W_2, W_{2+k}, …; the robot drives the others
    /// with the updater off), 1 to 10000 [default: 1]: k worlds of change meet the check at once.
    /// summary.json gains `heavy_change` (Suspend and Lost shares, stuck worlds).
    #[arg(long, value_name = "K", value_parser = super::count_in(1, 10_000), allow_hyphen_values = true)]
    pub update_every: Option<usize>,
    /// Smallest distance from an edited item to the route, metres (the generator's
    /// `route_clearance_m`, default 0.98: the robot's width plus 0.3 m); smaller values put
    /// edits near the route.
    #[arg(long, value_name = "METRES", value_parser = super::real_in(0.0, 100.0, "m"), allow_hyphen_values = true)]
    pub route_clearance: Option<f64>,
    /// Harder worlds: from W_2 on, each world's tour starts at a seeded waypoint and is driven
    /// either way, the robot starting there (the paper: one route, one start).
    #[arg(long)]
    pub route_variants: bool,
    /// Harder worlds: from W_2 on, people stop and stand at each waypoint for a seeded time up to
    /// this many seconds, 0 to 600 (the paper: people keep walking).
    #[arg(long, value_name = "SECONDS", value_parser = super::real_in(0.0, 600.0, "s"), allow_hyphen_values = true)]
    pub people_pause_s: Option<f64>,
    /// Worlds whose drive is also written as a ROS 2 MCAP bag (scans, odometry, /tf, truth,
    /// estimate, particles, verdicts, the map as it changes; docs/real-data.md), comma-separated
    /// world numbers from 2 to --worlds: `OUT[/PRESET]/mcap/PRESET-sSEED-WNNN.mcap`.
    #[arg(long, value_name = "I,J", value_delimiter = ',', value_parser = super::count_in(2, super::MAX_WORLDS), allow_hyphen_values = true)]
    pub mcap_worlds: Vec<usize>,
    /// Worlds whose maps are kept: `all`, or comma-separated world numbers from 2 to --worlds
    /// [default: 2,50,100 and the last]. Each keeps M_i, G_i, the error image E_i and the
    /// trajectories in seed-S/; report.md lists them and report.html steps through them.
    #[arg(long, value_name = "all|I,J", value_parser = str::parse::<SaveMaps>, allow_hyphen_values = true)]
    pub save_maps: Option<SaveMaps>,
    /// Do not time the updater (all timing fields 0: outputs bit-identical between runs).
    #[arg(long)]
    pub no_timing: bool,
    /// Run only the k-th of N slices of the seeds (1 ≤ k ≤ N ≤ --seeds); merge the shards'
    /// folders with `mapkeeper merge`.
    #[arg(long, value_name = "k/N", value_parser = str::parse::<Shard>, allow_hyphen_values = true)]
    pub shard: Option<Shard>,
    /// Robot file and sensor realism (recorded in summary.json's parameters when not the
    /// defaults).
    #[command(flatten)]
    pub sensor: super::sensor::SensorArgs,
    /// The updater's pose source (recorded in summary.json's parameters and in report.md when
    /// not the chain localiser).
    #[command(flatten)]
    pub poses: super::poses::PoseArgs,
}

/// `--save-maps`: every world, or the listed ones.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SaveMaps {
    /// W_2 … W_N.
    All,
    /// These worlds (each ≥ 2), sorted, without repeats.
    List(Vec<usize>),
}

impl std::str::FromStr for SaveMaps {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim() == "all" {
            return Ok(SaveMaps::All);
        }
        let mut worlds = Vec::new();
        for part in s.split(',') {
            let w: usize = part
                .trim()
                .parse()
                .map_err(|_| format!("`{part}` is neither `all` nor a world number (e.g. all, or 2,37,50)"))?;
            if w < 2 {
                return Err(format!("world {w}: saved worlds are W_2 or later (W_1 is always saved)"));
            }
            worlds.push(w);
        }
        worlds.sort_unstable();
        worlds.dedup();
        Ok(SaveMaps::List(worlds))
    }
}

impl SaveMaps {
    /// The worlds of a run of `worlds` worlds, or an error naming the flag.
    fn resolve(&self, worlds: usize) -> anyhow::Result<Vec<usize>> {
        match self {
            SaveMaps::All => Ok((2..=worlds).collect()),
            SaveMaps::List(list) => match list.iter().find(|&&w| w > worlds) {
                Some(w) => anyhow::bail!("--save-maps: world {w} is beyond --worlds {worlds}"),
                None => Ok(list.clone()),
            },
        }
    }
}

/// First seed of the default run (after the tuning seeds 1-3 of the algorithms issue).
const DEFAULT_SEED: u64 = 11;

/// Presets of the default run: the paper as written beside this project's preset.
const DEFAULT_PRESETS: [&str; 2] = ["paper", "mapkeeper"];

fn default_out(seed: u64, worlds: usize, shard: Option<Shard>) -> PathBuf {
    let part = shard.map(|s| format!("-shard{}of{}", s.index, s.count)).unwrap_or_default();
    super::numbered_out(&format!("validate-s{seed}-{worlds}w{part}"))
}

/// The output folders, made before anything runs: OUT itself, or for a sweep OUT (holding the
/// comparison) and `OUT/<preset>` inside it per preset, moved into place with OUT.
fn output_dirs(
    out: &Path,
    plan: &SweepPlan,
    sweep: bool,
    force: bool,
) -> anyhow::Result<(Option<StagedDir>, Vec<StagedDir>)> {
    let top = super::output_dir(out, force)?;
    if !sweep {
        return Ok((None, vec![top]));
    }
    let subs = plan.groups().iter().map(|&p| top.sub(&plan.presets[p])).collect::<Result<Vec<_>, _>>()?;
    Ok((Some(top), subs))
}

/// With `--mcap-worlds`: each preset's bags go to its folder's `mcap/`.
fn plan_mcap(plan: &mut SweepPlan, dirs: &[StagedDir], worlds: &[usize]) -> anyhow::Result<()> {
    if worlds.is_empty() {
        return Ok(());
    }
    for (p, dir) in plan.groups().into_iter().zip(dirs) {
        let mcap_dir = dir.path().join("mcap");
        std::fs::create_dir_all(&mcap_dir).with_context(|| format!("{}", mcap_dir.display()))?;
        plan.params[p].mcap_worlds = worlds.to_vec();
        plan.params[p].mcap_dir = Some(mcap_dir);
    }
    Ok(())
}

/// Fewer runs than threads: a free core runs each run's simulator ahead of its estimators (the
/// same results bit for bit; docs/benchmarks.md).
fn simulate_ahead_if_cores_free(
    plan: &mut mapkeeper_scenario::SweepPlan,
    runs: usize,
    pool: rayon::ThreadPool,
) -> rayon::ThreadPool {
    let ahead = runs < pool.current_num_threads();
    for p in &mut plan.params {
        p.runner.simulate_ahead = ahead;
    }
    pool
}

/// The flags that override fields of every preset's parameters.
fn apply_overrides(args: &Args, plan: &mut SweepPlan) -> anyhow::Result<()> {
    let poses = args.poses.updater_poses()?;
    let saved = args.save_maps.as_ref().map(|s| s.resolve(args.worlds)).transpose()?;
    for p in &mut plan.params {
        if let Some(saved) = &saved {
            p.saved_worlds.clone_from(saved);
        }
        p.runner.updater_poses = poses;
        if let Some(k) = args.update_every {
            p.update_every = k;
        }
        if let Some(c) = args.route_clearance {
            p.generator.route_clearance_m = c;
        }
        p.generator.route_variants |= args.route_variants;
        if let Some(s) = args.people_pause_s {
            p.generator.people_pause_s = s;
        }
        p.validate().context("--update-every / --route-clearance / --people-pause-s")?;
        args.sensor.apply(&mut p.runner.sim)?;
    }
    Ok(())
}

/// The sweep the flags ask for (W_1 loaded and resolved).
fn spec_of(args: &Args) -> anyhow::Result<SweepSpec> {
    let presets = match (&args.presets, &args.preset) {
        (Some(list), _) => list.clone(),
        (None, Some(one)) => vec![one.clone()],
        (None, None) => DEFAULT_PRESETS.iter().map(ToString::to_string).collect(),
    };
    Ok(SweepSpec {
        presets,
        worlds: args.worlds,
        first_seed: args.seed,
        seeds: args.seeds as u64,
        route_length_m: args.route_length,
        shard: args.shard,
        localiser: args.localiser.clone(),
        ground_truth: args.ground_truth,
        site: super::load_site(args.world.as_deref(), args.route.as_deref(), true)?,
    })
}

/// What a validation is about to run and where it writes (printed before the first world, so a
/// user who typed the bare command knows what it does before the progress bar).
fn plan_line(args: &Args, plan: &SweepPlan, out: &Path, to_run: usize, threads: usize) -> String {
    let mut seeds: Vec<u64> = plan.jobs.iter().map(|j| j.1).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let seeds = match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if b - a + 1 == seeds.len() as u64 && a != b => format!("seeds {a}-{b}"),
        _ => format!("seed(s) {}", seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")),
    };
    let presets: Vec<&str> = plan.groups().into_iter().map(|p| plan.presets[p].as_str()).collect();
    let poses = plan.params.first().map_or("localiser", |p| p.runner.updater_poses.name());
    format!(
        "validate: preset(s) {} × {seeds} × {} worlds (W_2-W_{}), localiser {}, updater poses {poses}, ground truth {}; \
{} job(s), {to_run} to run, on {threads} thread(s); writing {} (a killed run continues with --resume --out)",
        presets.join(", "),
        args.worlds,
        args.worlds,
        args.localiser,
        args.ground_truth.name(),
        plan.jobs.len(),
        out.display()
    )
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sweep = args.preset.is_none();
    let spec = spec_of(&args)?;
    mapkeeper_localiser::FilterParams::preset(&args.localiser).context("--localiser")?;
    let mut plan = spec.plan()?;
    if let Some(file) = args.updater_params.as_deref() {
        for p in &mut plan.params {
            p.runner.updater = super::load_params(p.runner.updater.clone(), Some(file), UpdaterParams::validate)?;
        }
    }
    apply_overrides(&args, &mut plan)?;
    let out = args.out.clone().unwrap_or_else(|| default_out(args.seed, args.worlds, args.shard));
    if let Some(&w) = args.mcap_worlds.iter().find(|&&w| w > args.worlds) {
        anyhow::bail!("--mcap-worlds: world {w} is beyond --worlds {}", args.worlds);
    }
    if args.resume && is_complete(&out, &plan, sweep, &args)? {
        outln!("validate: {} is complete (--resume): nothing to run", out.display());
        return Ok(());
    }
    let (top, dirs) = output_dirs(&out, &plan, sweep, args.force)?;
    plan_mcap(&mut plan, &dirs, &args.mcap_worlds)?;
    let checkpoints = Checkpoints::beside(&out);
    let done = finished_jobs(&plan, &checkpoints, &out, args.resume)?;
    let start = Instant::now();
    let wall = super::Wall::start();
    let clock: &dyn Clock = if args.no_timing { &NoClock } else { &wall };
    let to_run = done.iter().filter(|d| d.is_none()).count();
    let pool = simulate_ahead_if_cores_free(&mut plan, to_run, super::thread_pool(args.jobs)?);
    let threads = pool.current_num_threads();
    let progress = SweepProgress::new(&plan, &args.localiser, threads, done.iter().map(Option::is_some).collect());
    outln!("{}", plan_line(&args, &plan, &out, to_run, threads));
    outln!("validate: {}; Ctrl-C stops it as a kill does (--resume continues)", describe(progress.estimate()));
    let runs =
        pool.install(|| plan.run_resuming(done, Some(&checkpoints), clock, &|k, w| progress.world_done(k, w)))?;
    progress.finish();
    let elapsed_s = start.elapsed().as_secs_f64();
    let wall_time_s = if args.no_timing { 0.0 } else { elapsed_s };
    let mut records = Vec::new();
    for (p, dir) in plan.groups().into_iter().zip(dirs) {
        let group = plan.runs_of(p, &runs);
        let record = ValidationRecord::new(&plan.params[p], &group, !args.no_timing, wall_time_s, args.shard);
        let summary = write_validation(&dir, &group, &record)?;
        if let Some((_, site)) = &spec.site {
            dir.write("world.toml", site.world.to_toml_string()?.as_bytes())?;
        }
        let written = dir.finish()?;
        let seeds: Vec<u64> = group.iter().map(|r| r.seed).collect();
        let shard =
            args.shard.map(|s| format!(" (shard {}/{}: seeds {:?})", s.index, s.count, seeds)).unwrap_or_default();
        let (n, preset) = (seeds.len(), &plan.presets[p]);
        outln!(
            "validate: {n} seed(s) × {} worlds, preset {preset}, localiser {}, {elapsed_s:.1} s wall{shard}",
            args.worlds,
            args.localiser
        );
        out!("{}", summary.table());
        outln!("wrote {}", written.display());
        records.push(record);
    }
    if let Some(top) = top {
        let records: Vec<&ValidationRecord> = records.iter().collect();
        let c = Comparison::new(&plan.presets, &records);
        write_comparison(&top, &c, &records)?;
        top.finish()?;
        outln!(
            "wrote {} and {} (presets side by side)",
            out.join("summary.json").display(),
            out.join("report.md").display()
        );
    }
    checkpoints.remove()?;
    Ok(())
}

/// The jobs a killed run had finished (with --resume; in job order, `None`: to run), or none,
/// discarding what an interrupted run left (without --resume).
fn finished_jobs(
    plan: &SweepPlan,
    checkpoints: &Checkpoints,
    out: &Path,
    resume: bool,
) -> anyhow::Result<Vec<Option<mapkeeper_scenario::SeedRun>>> {
    if resume {
        let done = plan.load_checkpoints(checkpoints)?;
        let n = done.iter().flatten().count();
        outln!("validate: resuming {}: {n} of {} job(s) already done", out.display(), done.len());
        return Ok(done);
    }
    let n = checkpoints.count();
    if n > 0 {
        errln!(
            "mapkeeper: note: {}: discarded {n} finished job(s) of an interrupted run (--resume keeps them)",
            checkpoints.dir().display()
        );
    }
    checkpoints.remove()?;
    Ok(vec![None; plan.jobs.len()])
}

/// Whether OUT holds the finished outputs of this very run (each preset's summary.json with
/// the same parameters, and for a sweep the comparison): `validate --resume` then has nothing
/// to do. An OUT that holds another run's results is an error.
fn is_complete(out: &Path, plan: &SweepPlan, sweep: bool, args: &Args) -> anyhow::Result<bool> {
    if !out.join("summary.json").is_file() {
        return Ok(false);
    }
    for p in plan.groups() {
        let dir = if sweep { out.join(&plan.presets[p]) } else { out.to_path_buf() };
        let file = dir.join("summary.json");
        let text = std::fs::read_to_string(&file).with_context(|| format!("--resume: {}", file.display()))?;
        let json: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("--resume: {}", file.display()))?;
        // As the run writes them: with the bags it was asked for.
        let mut params = plan.params[p].clone();
        params.mcap_worlds.clone_from(&args.mcap_worlds);
        let (want, want_shard) = (serde_json::to_value(&params)?, serde_json::to_value(args.shard)?);
        if json.get("params") != Some(&want) || json.get("shard").unwrap_or(&serde_json::Value::Null) != &want_shard {
            anyhow::bail!(
                "--resume: {} holds a run with other parameters or another shard than these flags (use another --out)",
                file.display()
            );
        }
    }
    Ok(true)
}
