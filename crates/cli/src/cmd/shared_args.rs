//! The flags several commands share, declared once and flattened into each command's arguments
//! (`#[command(flatten)]`): where the output goes, how many threads, which world. Each
//! command's own help says what its output folder holds and its default name.
//!
//! `--localiser` is not among them: its default is the command's (`amcl` for the paper's
//! experiments, `mapkeeper` for the recovery suite, `auto` for a log), and its help names what
//! the preset drives there.

use std::path::PathBuf;
use std::time::Instant;

/// `--out DIR` with a default (a new numbered folder under `results/`, named in the command's
/// help) and `--force`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct OutputArgs {
    /// Output folder (default: a new numbered folder under results/, named below).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
}

/// `--out DIR`, required, and `--force`.
#[derive(clap::Args, Debug, Clone)]
pub struct RequiredOutputArgs {
    /// Output folder (written atomically; an existing non-empty folder is refused without --force).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
}

/// `--jobs N`.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct JobsArg {
    /// Worker threads, 1 to 1024 (default: all cores; more threads than runs gain nothing; the
    /// results are the same for any count).
    #[arg(long, value_name = "N", value_parser = super::jobs, allow_hyphen_values = true)]
    pub jobs: Option<usize>,
}

/// `--world` and `--route`: the world W_1 the command's worlds grow from.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct WorldArgs {
    /// The world W_1: `warehouse` (the embedded AWS small warehouse, the default), `lab` (the
    /// paper's lab, §5.5), or a world file (docs/world-format.md; an imported map: `mapkeeper
    /// import-map`). Its storage areas and route come from the file, or are derived and planned
    /// when it has none.
    #[arg(long, value_name = "NAME|FILE")]
    pub world: Option<PathBuf>,
    /// Route file (docs/world-format.md) overriding the world's route (the tour).
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
}

impl WorldArgs {
    /// The world with its scenario resolved, as the commands that generate worlds need it
    /// ([`super::load_site`] with storage areas required); `None` without either flag.
    pub fn load(&self) -> anyhow::Result<Option<(String, mapkeeper_closed_loop::Site)>> {
        super::load_site(self.world.as_deref(), self.route.as_deref(), true)
    }
}

/// `--no-timing`: outputs without wall-clock times, so that two runs of the same seed write the
/// same bytes (the project's determinism promise covers everything but times).
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct TimingArg {
    /// Do not time anything (every time field and wall time 0: outputs bit-identical between
    /// runs of the same seed).
    #[arg(long)]
    pub no_timing: bool,
}

impl TimingArg {
    /// The clock the estimators are timed with: `wall`, or none with `--no-timing`.
    pub fn clock<'a>(&self, wall: &'a super::Wall) -> &'a dyn mapkeeper_harness::Clock {
        if self.no_timing { &mapkeeper_harness::NoClock } else { wall }
    }

    /// Seconds since `start`, or 0 with `--no-timing` (what the outputs record).
    pub fn wall_s(&self, start: Instant) -> f64 {
        if self.no_timing { 0.0 } else { start.elapsed().as_secs_f64() }
    }
}
