//! The initial map M_1: the project's own log-odds occupancy mapper fed with noisy simulated
//! scans along an exploration route at the simulator's true poses (people moving), standing in
//! for the paper's SLAM Toolbox run by teleoperation.

use crate::sim_source::SimSource;
use crate::worlds::WorldsError;
use mapkeeper_common::ParamError;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_grid::{GridGeometry, OccupancyGrid};
use mapkeeper_harness::jobs::map::TruthMapper;
use mapkeeper_harness::{NoClock, PoseSource, Session};
use mapkeeper_sim::seeds::stream_seed;
use mapkeeper_sim::{Route, SimParams, Simulator, World};
use serde::{Deserialize, Serialize};

/// Parameters of the M_1 exploration run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MappingParams {
    /// The log-odds mapper.
    pub mapper: MapperParams,
    /// Integrate every k-th scan tick (≥ 1). Default 2 (6.25 Hz with the S300 pair).
    pub scan_stride: u32,
    /// The run stops after this much simulated time even if the route is not done, seconds.
    /// Default 400.
    pub max_sim_time_s: f64,
    /// Whether scans with a sweep timing (the simulator's `motion-distortion`) are deskewed by
    /// the true motion before they are integrated, as a survey would. Default true (written
    /// only when false).
    #[serde(default = "deskew_default", skip_serializing_if = "is_deskew_default")]
    pub deskew: bool,
}

fn deskew_default() -> bool {
    true
}

fn is_deskew_default(on: &bool) -> bool {
    *on
}

impl Default for MappingParams {
    fn default() -> Self {
        Self { mapper: MapperParams::default(), scan_stride: 2, max_sim_time_s: 400.0, deskew: true }
    }
}

impl MappingParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), WorldsError> {
        self.mapper.validate()?;
        if self.scan_stride == 0 {
            return Err(WorldsError::InvalidParam(ParamError::rule("scan_stride", "must be ≥ 1")));
        }
        if !(self.max_sim_time_s.is_finite() && self.max_sim_time_s > 0.0) {
            return Err(WorldsError::InvalidParam(ParamError::new(
                "max_sim_time_s",
                self.max_sim_time_s,
                "must be a finite time > 0 s",
            )));
        }
        Ok(())
    }
}

/// What the exploration run produced.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialMap {
    /// M_1.
    pub map: OccupancyGrid,
    /// Scans integrated.
    pub scans: u64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// Whether the exploration route was completed.
    pub route_done: bool,
}

/// Builds M_1 in `world` by driving `route` (simulator seeded from `seed`, stream `"mapping"`).
/// Invalid beams (no return, dropouts) are not integrated.
pub fn build_initial_map(
    world: &World,
    route: &Route,
    geometry: &GridGeometry,
    sim_params: &SimParams,
    params: &MappingParams,
    seed: u64,
) -> Result<InitialMap, WorldsError> {
    params.validate()?;
    let mut mapper =
        TruthMapper::new(*geometry, params.mapper, u64::from(params.scan_stride), 0.0)?.with_deskew(params.deskew);
    let mut sim = Simulator::new(world, sim_params.clone(), stream_seed(seed, "mapping"))?;
    sim.set_route(route.points());
    let mut source = SimSource::new(sim, params.max_sim_time_s);
    let mut session = Session::new(PoseSource::None, None, None, &NoClock);
    mapkeeper_harness::run(&mut source, &mut session, &mut [], &mut [&mut mapper])?;
    Ok(InitialMap {
        map: mapper.mapper.to_grid(),
        scans: mapper.scans,
        sim_time_s: source.sim_time_s(),
        route_done: source.route_done(),
    })
}
