//! The robot's own kept map in a robustness experiment: `M_{k-1}`, the map the updater under
//! test made of W_2 … W_{k-1} from M_1, carried world to world with its cross-world memory as
//! the validation carries it (`validate`'s chain: the same worlds, routes, run labels and M_1).
//! An experiment that localises on it measures the lifelong setting the paper is about, where
//! the robot's map is kept current, rather than the harshest case of a map ten or a hundred
//! worlds old ([`Setup::chain_maps`]).

use super::Setup;
use crate::ExperimentError;
use crate::runner::{NoClock, RunInputs, RunnerParams, run_world};
use mapkeeper_grid::OccupancyGrid;
use mapkeeper_updater::StructureMemory;
use std::collections::{BTreeMap, BTreeSet};

/// The chain's map after one world, and the updater's cross-world memory with it.
#[derive(Clone, Debug)]
pub struct ChainMap {
    /// M_i.
    pub map: OccupancyGrid,
    /// The memory the updater carried out of W_i (empty for M_1, a surveyed map).
    pub memory: StructureMemory,
}

impl Setup {
    /// M_i for every i in `keep`, each with the memory carried out of W_i: the chain run from
    /// M_1 through W_2 … W_max(keep) with `runner` (its updater, localiser and controls), world
    /// i under the run label `W<iii>` as `validate` labels it, on each world's route. M_1 is
    /// the surveyed map with an empty memory. Runs in order (a chain); nothing is timed. An
    /// error names a world that was not generated.
    pub fn chain_maps(
        &self,
        runner: &RunnerParams,
        seed: u64,
        keep: &BTreeSet<usize>,
    ) -> Result<BTreeMap<usize, ChainMap>, ExperimentError> {
        let mut out = BTreeMap::new();
        let Some(&last) = keep.last() else { return Ok(out) };
        self.world(last)?;
        let mut prev = ChainMap { map: self.m1.clone(), memory: StructureMemory::default() };
        if keep.contains(&1) {
            out.insert(1, prev.clone());
        }
        for i in 2..=last {
            let (world, route) = (&self.chain.worlds[i - 1], &self.chain.routes[i - 1]);
            let inputs = RunInputs {
                world,
                route,
                prev_map: &prev.map,
                baseline_map: &self.m1,
                prev_memory: Some(&prev.memory),
            };
            let run = run_world(&inputs, runner, seed, &format!("W{i:03}"), &NoClock)?;
            prev = ChainMap { map: run.map, memory: run.memory };
            if keep.contains(&i) {
                out.insert(i, prev.clone());
            }
        }
        Ok(out)
    }
}
