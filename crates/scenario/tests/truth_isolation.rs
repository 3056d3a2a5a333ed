//! Truth never reaches an estimator: the same simulated run with its truth replaced by garbage
//! (random poses, NaN distances) gives bit-identical estimates, verdicts, recoveries and maps.
#![allow(clippy::unwrap_used)]

use mapkeeper_closed_loop::{GeneratorParams, LostPolicy, SimSource, generate_worlds};
use mapkeeper_grid::Pose2;
use mapkeeper_harness::{
    Control, NoClock, Observer, PoseSource, RobotControl, SensorSource, Session, SessionStep, SourceError, Step, Truth,
};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{Route, SimParams, Simulator, World, ground_truth_map};
use mapkeeper_updater::{MapUpdater, UpdaterParams};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

/// Wraps a source and replaces every truth it hands out by garbage.
struct GarbageTruth<S> {
    inner: S,
    rng: ChaCha8Rng,
}

impl<S: SensorSource> SensorSource for GarbageTruth<S> {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        let mut step = self.inner.next_step()?;
        if let Some(s) = step.as_mut() {
            let pose =
                Pose2::new(self.rng.random_range(-1e3..1e3), self.rng.random_range(-1e3..1e3), self.rng.random());
            s.truth = Some(Truth { pose_in_map: pose, distance_m: f64::NAN });
        }
        Ok(step)
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        self.inner.control()
    }
}

/// Records what the estimators said, never the truth.
#[derive(Default)]
struct Estimates(Vec<String>);

impl Observer for Estimates {
    fn on_step(&mut self, _step: &Step, r: &SessionStep, _session: &Session<'_>) {
        let u =
            r.updater.as_ref().map(|u| (u.outcome, u.verdict, u.n_dc, u.changed_cells.len(), u.pose_recovery.clone()));
        self.0.push(format!(
            "{} {:?} {:?} {u:?}",
            r.stamp_ns,
            r.pose_in_map.map(|p| (p.x.to_bits(), p.y.to_bits(), p.yaw.to_bits())),
            r.localiser.map(|l| l.estimate.covariance)
        ));
    }
}

fn run(world: &World, route: &Route, map: &mapkeeper_grid::OccupancyGrid, garbage: bool) -> (Vec<String>, Vec<u8>) {
    let mut sim = Simulator::new(world, SimParams::default(), 5).unwrap();
    sim.set_route(route.points());
    let start = sim.true_pose();
    let start_est = Pose2::new(start.x + 0.4, start.y - 0.3, start.yaw + 0.1);
    let cov = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.0025]];
    let mut chain = Localiser::new(map, FilterParams::default(), 11).unwrap();
    chain.init_pose(start_est, cov).unwrap();
    let updater = MapUpdater::new(map.clone(), UpdaterParams::paper()).unwrap();
    let mut session = Session::new(PoseSource::Localiser(Box::new(chain)), Some(updater), None, &NoClock);
    let mut lost = LostPolicy::new(true, 2.0, cov);
    let mut est = Estimates::default();
    let controls: &mut [&mut dyn Control] = &mut [&mut lost];
    let sim_source = SimSource::new(sim, 60.0);
    if garbage {
        let mut source = GarbageTruth { inner: sim_source, rng: ChaCha8Rng::seed_from_u64(3) };
        mapkeeper_harness::run(&mut source, &mut session, controls, &mut [&mut est]).unwrap();
    } else {
        let mut source = sim_source;
        mapkeeper_harness::run(&mut source, &mut session, controls, &mut [&mut est]).unwrap();
    }
    let out = session.finish().unwrap();
    let map = out.updater.unwrap().map().cells().iter().map(|c| *c as u8).collect();
    (est.0, map)
}

#[test]
fn garbage_truth_gives_bit_identical_estimates_and_maps() {
    let chain =
        generate_worlds(&World::default_warehouse(), &Route::default_warehouse(), 3, 4, &GeneratorParams::default())
            .unwrap();
    let w1 = &chain.worlds[0];
    // Drive the third world on the first world's map: the updater has changes to find.
    let map = ground_truth_map(w1, &w1.default_map_geometry(0.05).unwrap());
    let route = ValidationParams::short_route(10.0);
    let (a, map_a) = run(&chain.worlds[2], &route, &map, false);
    let (b, map_b) = run(&chain.worlds[2], &route, &map, true);
    assert!(a.len() > 50, "only {} steps", a.len());
    assert_eq!(a, b);
    assert_eq!(map_a, map_b);
}
