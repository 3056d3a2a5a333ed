//! The fixed scene of `mapkeeper bench`: W_2 of the default chain and its first steps,
//! recorded once from the simulator.

use super::*;

/// One recorded step of the scene.
pub(super) struct SceneStep {
    pub(super) frame: SensorFrame,
    pub(super) truth: Pose2,
}

/// The fixed scene every row runs on.
pub(super) struct Scene {
    pub(super) w2: World,
    pub(super) route: Route,
    pub(super) map: OccupancyGrid,
    pub(super) steps: Vec<SceneStep>,
    pub(super) params: ValidationParams,
}

pub(super) fn build_scene(seed: u64, steps: usize) -> anyhow::Result<Scene> {
    let params = ValidationParams::new(2, "paper")?;
    let w1 = World::default_warehouse();
    let chain = generate_worlds(&w1, &params.route, 2, seed, &params.generator)?;
    let geometry = w1.default_map_geometry(params.resolution_m)?;
    let map = ground_truth_map(&w1, &geometry);
    let (w2, route) = (chain.worlds[1].clone(), chain.routes[1].clone());
    let (_, recorded) = simulate(&w2, &route, &params, seed, steps)?;
    anyhow::ensure!(
        recorded.len() == steps,
        "the scene's route ends after {} steps; use --steps ≤ that",
        recorded.len()
    );
    Ok(Scene { w2, route, map, steps: recorded, params })
}

/// Drives `route` in `world` for `steps` lidar steps; (simulated seconds, the steps).
pub(super) fn simulate(
    world: &World,
    route: &Route,
    params: &ValidationParams,
    seed: u64,
    steps: usize,
) -> anyhow::Result<(f64, Vec<SceneStep>)> {
    let mut sim = Simulator::new(world, params.runner.sim.clone(), seed)?;
    sim.set_route(route.points());
    let mut source = SimSource::new(sim, params.runner.max_sim_time_s);
    let mut out = Vec::with_capacity(steps);
    while out.len() < steps {
        let Some(step) = source.next_step()? else { break };
        let truth = step.truth.map_or(Pose2::new(0.0, 0.0, 0.0), |t| t.pose_in_map);
        out.push(SceneStep { frame: step.frame, truth });
    }
    Ok((source.sim_time_s(), out))
}
