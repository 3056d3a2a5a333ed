//! The run of one seed: W_1 … W_N generated, M_1 built, then every world's closed loop on
//! M_{i-1} with the baseline on M_1, each world judged against its ground truth.

use super::params::{GroundTruth, ValidationParams};
use super::record::{GroundTruthScores, SavedWorld, SeedRun, WorldRow};
use crate::experiments::ExperimentError;
use crate::experiments::scores::Scores;
use crate::experiments::validation::erosion::{ChangeClasses, ErosionJudge, Retention};
use crate::stats::median;
use mapkeeper_closed_loop::runner::{Checked, Clock, Execution, RunInputs, run_world_with};
use mapkeeper_closed_loop::worlds::generator::generate_worlds;
use mapkeeper_closed_loop::worlds::mapping::build_initial_map;
use mapkeeper_closed_loop::worlds::observed::{OBSERVATION_STEP_M, restrict_to, route_poses, visible_cells};
use mapkeeper_grid::metrics::{interior_mask, map_metrics, map_metrics_in};
use mapkeeper_grid::{GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_sim::{World, ground_truth_map};
use std::path::Path;

/// What one seed's validation is given beside its parameters, never inside them: W_1 (with
/// its scenario resolved; `None`: the embedded default warehouse), how its worlds are run (the
/// threads and the clock of the updater's time per scan) and where the MCAP bags of the
/// parameters' `mcap_worlds` go.
#[derive(Clone, Copy)]
pub struct ValidationRun<'a> {
    /// W_1; `None`: the embedded default warehouse.
    pub w1: Option<&'a World>,
    /// Threads and clock of every world's run.
    pub exec: Execution<'a>,
    /// The folder of the MCAP bags (`mcap_worlds`); `None`: no bag is written.
    pub mcap_dir: Option<&'a Path>,
}

impl<'a> ValidationRun<'a> {
    /// In the embedded default warehouse, default threads, timed by `clock`, no bags.
    pub fn timed_by(clock: &'a dyn Clock) -> Self {
        ValidationRun { w1: None, exec: Execution::timed_by(clock), mcap_dir: None }
    }
}

/// Runs the validation for one seed; the parameters are checked once, here. `progress(i)` is
/// called after each world i (and with 1 after M_1).
pub fn run_seed(
    params: &ValidationParams,
    seed: u64,
    run: &ValidationRun<'_>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SeedRun, ExperimentError> {
    params.validate()?;
    // The parameters name the world (`use_site` set its routes); the world itself comes beside
    // them: both or neither, or the site's routes would be driven in another world.
    if params.world.is_some() != run.w1.is_some() {
        return Err(ExperimentError::Invalid(format!(
            "the parameters name the world {:?} but the run is given {}",
            params.world,
            if run.w1.is_some() { "a world" } else { "none (the default warehouse)" }
        )));
    }
    let default;
    let w1 = match run.w1 {
        Some(w) => w,
        None => {
            default = World::default_warehouse();
            &default
        }
    };
    run_chain(w1, params, seed, run, progress)
}

/// The file name of the MCAP bag of world `i` of a seed (`--mcap-worlds`).
pub fn mcap_name(preset: &str, seed: u64, i: usize) -> String {
    format!("{preset}-s{seed}-W{i:03}.mcap")
}

/// What [`Judge::world`] makes of one world.
struct Judged {
    /// M_1, M_i, M*_i and F_i against the run's ground truth.
    chosen: GroundTruthScores,
    /// The same against the other variant.
    other: GroundTruthScores,
    /// G_i of the run's variant.
    gi: OccupancyGrid,
    /// Structure retention against the exact G_i.
    retention: Retention,
    /// Change classes against the exact G_i.
    change_classes: ChangeClasses,
}

/// Scores maps against both ground truth variants of each world, keeps the best achievable
/// map M*_i of the chain, and scores structure retention and change classes.
struct Judge<'a> {
    params: &'a ValidationParams,
    /// Inside the outer walls of W_1 (they never move: one interior for every world).
    interior: Vec<bool>,
    /// Observation poses along the exploration route (the observed ground truth).
    exploration: Vec<Pose2>,
    /// Observation poses along the route (what an updater can see).
    route: Vec<Pose2>,
    /// M*_i.
    best: OccupancyGrid,
    /// The exact G_1.
    g1: OccupancyGrid,
    /// The running structure mask S_i and W_1's movable items.
    erosion: ErosionJudge,
}

impl<'a> Judge<'a> {
    fn new(
        params: &'a ValidationParams,
        w1: &World,
        m1: &OccupancyGrid,
        g1: OccupancyGrid,
    ) -> Result<Self, ExperimentError> {
        Ok(Judge {
            params,
            interior: interior_mask(&g1),
            exploration: route_poses(&params.exploration_route, OBSERVATION_STEP_M),
            route: route_poses(&params.route, OBSERVATION_STEP_M),
            best: m1.clone(),
            erosion: ErosionJudge::new(w1, m1, &g1)?,
            g1,
        })
    }

    fn observed(&self, exact: &OccupancyGrid) -> OccupancyGrid {
        restrict_to(exact, &visible_cells(exact, &self.exploration, &self.params.runner.sim.lidars))
    }

    /// G_1 of the run's variant and M_1 against it.
    fn initial(&self, m1: &OccupancyGrid) -> Result<(OccupancyGrid, Scores), ExperimentError> {
        let metrics = &self.params.metrics;
        Ok(match self.params.ground_truth {
            GroundTruth::Exact => (self.g1.clone(), Scores::from(map_metrics(m1, &self.g1, metrics)?)),
            GroundTruth::Observed => {
                let observed = self.observed(&self.g1);
                let scores = Scores::from(map_metrics_in(m1, &observed, &self.interior, metrics)?);
                (observed, scores)
            }
        })
    }

    /// Advances M*_{i-1} to M*_i and S_{i-1} to S_i with W_i `wi` and its exact G_i `gi`, and
    /// scores M_1, M_i, M*_i and F_i.
    fn world(
        &mut self,
        wi: &World,
        gi: OccupancyGrid,
        m1: &OccupancyGrid,
        mi: &OccupancyGrid,
        fresh: &OccupancyGrid,
    ) -> Result<Judged, ExperimentError> {
        let seen = visible_cells(&gi, &self.route, &self.params.runner.sim.lidars);
        for ((cell, &truth), &seen) in self.best.cells_mut().iter_mut().zip(gi.cells()).zip(&seen) {
            if seen {
                *cell = truth;
            }
        }
        let (retention, change_classes) = self.erosion.world(wi, &gi, &seen, m1, [mi, &self.best, fresh])?;
        let metrics = &self.params.metrics;
        let exact = GroundTruthScores {
            static_map: Scores::from(map_metrics(m1, &gi, metrics)?),
            updated_map: Scores::from(map_metrics(mi, &gi, metrics)?),
            best_map: Scores::from(map_metrics(&self.best, &gi, metrics)?),
            fresh_map: Scores::from(map_metrics(fresh, &gi, metrics)?),
        };
        let observed_gi = self.observed(&gi);
        let inside = |m: &OccupancyGrid| map_metrics_in(m, &observed_gi, &self.interior, metrics).map(Scores::from);
        let observed = GroundTruthScores {
            static_map: inside(m1)?,
            updated_map: inside(mi)?,
            best_map: inside(&self.best)?,
            fresh_map: inside(fresh)?,
        };
        let (chosen, other, gi) = match self.params.ground_truth {
            GroundTruth::Exact => (exact, observed, gi),
            GroundTruth::Observed => (observed, exact, observed_gi),
        };
        Ok(Judged { chosen, other, gi, retention, change_classes })
    }
}

/// One world of the chain, recorded as an MCAP bag when `params.mcap_worlds` asks for it.
fn run_chain_world(
    inputs: &RunInputs<'_>,
    rp: Checked<'_>,
    params: &ValidationParams,
    seed: u64,
    i: usize,
    run: &ValidationRun<'_>,
) -> Result<mapkeeper_closed_loop::runner::WorldRun, ExperimentError> {
    let label = format!("W{i:03}");
    match run.mcap_dir {
        Some(dir) if params.mcap_worlds.contains(&i) => {
            let path = dir.join(mcap_name(&params.preset, seed, i));
            let mut rec = mapkeeper_harness::mcap_out::McapRecorder::create(&path)?;
            let world_run = run_world_with(inputs, rp, seed, &label, &run.exec, &mut [&mut rec])?;
            rec.finish(Some(&world_run.map))?;
            Ok(world_run)
        }
        _ => run_world_with(inputs, rp, seed, &label, &run.exec, &mut []),
    }
}

/// The chain of one seed from W_1, its parameters checked.
fn run_chain(
    w1: &World,
    params: &ValidationParams,
    seed: u64,
    run: &ValidationRun<'_>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SeedRun, ExperimentError> {
    let geometry: GridGeometry = w1.default_map_geometry(params.resolution_m)?;
    let chain = generate_worlds(w1, &params.route, params.worlds, seed, &params.generator)?;
    let m1 = build_initial_map(w1, &params.exploration_route, &geometry, &params.runner.sim, &params.mapping, seed)?;
    let mut judge = Judge::new(params, w1, &m1.map, ground_truth_map(w1, &geometry))?;
    let (g1, initial_scores) = judge.initial(&m1.map)?;
    progress(1);
    let mut rows = Vec::with_capacity(params.worlds - 1);
    let mut saved = Vec::new();
    let mut all_times = Vec::new();
    let mut prev = m1.map.clone();
    // The updater's cross-world memory: M_1 is a surveyed map (empty memory: all established).
    let mut memory = mapkeeper_updater::StructureMemory::default();
    for (k, world) in chain.worlds.iter().enumerate().skip(1) {
        let i = k + 1;
        let keep = params.saved_worlds.contains(&i);
        let mut rp = params.runner.clone();
        rp.record_trajectories = keep;
        rp.run_updater = rp.run_updater && (i - 2).is_multiple_of(params.update_every);
        let inputs = RunInputs {
            world,
            route: &chain.routes[k],
            prev_map: &prev,
            baseline_map: &m1.map,
            prev_memory: Some(&memory),
        };
        // `params.validate` checked the runner; only two flags changed.
        let run = run_chain_world(&inputs, Checked::assume(&rp), params, seed, i, run)?;
        // Validated: runner.fresh_map is set, so every run returns its fresh map.
        let fresh = run.fresh_map.as_ref().unwrap_or(&run.map);
        let Judged { chosen, other, gi, retention, change_classes } =
            judge.world(world, ground_truth_map(world, &geometry), &m1.map, &run.map, fresh)?;
        let median_scan_us = median(run.scan_times_us.iter().map(|&t| f64::from(t)).collect()).unwrap_or(0.0);
        all_times.extend_from_slice(&run.scan_times_us);
        rows.push(WorldRow {
            seed,
            world: i,
            edits: chain.edits[k].len(),
            movable_items: world.movable.len(),
            static_map: chosen.static_map,
            updated_map: chosen.updated_map,
            best_map: chosen.best_map,
            fresh_map: chosen.fresh_map,
            other_ground_truth: other,
            loc_static: run.baseline,
            loc_updated: run.chain,
            updater: run.updater,
            cells_changed: run.cells_changed,
            collisions: run.collisions,
            sim_time_s: run.sim_time_s,
            distance_m: run.distance_m,
            route_done: run.route_done,
            median_scan_us,
            lost: run.lost,
            retention: Some(retention),
            change_classes: Some(change_classes),
            updater_pose_error: run.given_pose,
        });
        if keep {
            saved.push(SavedWorld {
                world: i,
                map: run.map.clone(),
                ground_truth: gi,
                trajectories: run.trajectories.clone(),
            });
        }
        prev = run.map;
        memory = run.memory;
        progress(i);
    }
    Ok(SeedRun {
        seed,
        initial_map: m1.map,
        initial_ground_truth: g1,
        initial_scores,
        rows,
        edits: chain.edits,
        saved,
        scan_times_us: all_times,
    })
}
