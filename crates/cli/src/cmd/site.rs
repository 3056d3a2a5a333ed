//! `--world` and `--route`: the world a command runs in and the route its robot drives (and W_1 of
//! the recovery family: `recover` and the experiments).

use anyhow::Context;
use std::path::Path;

/// `--world` and `--route` of `validate`, `generate`, `recover`, `run` and the experiments: the world (an
/// embedded world's name, `warehouse` or `lab`, or a world file) with its scenario resolved
/// (storage areas and route from the file, derived or planned when absent; the route file
/// overrides the world's route), and the name it goes by in the outputs. `None` when neither
/// flag is given: the commands keep their defaults (the embedded warehouse, unchanged).
/// With `need_areas` (the commands that generate worlds), a world whose storage areas can be
/// neither read nor derived is refused.
pub fn load_site(
    world: Option<&Path>,
    route: Option<&Path>,
    need_areas: bool,
) -> anyhow::Result<Option<(String, mapkeeper_closed_loop::Site)>> {
    if world.is_none() && route.is_none() {
        return Ok(None);
    }
    let world_arg = world.unwrap_or(Path::new("warehouse"));
    let w = mapkeeper_sim::World::named_or_load(world_arg).context("--world")?;
    let name = world_arg.display().to_string();
    let origin = match world_arg.to_str() {
        Some(n) if mapkeeper_sim::EMBEDDED_WORLDS.contains(&n) => format!("world {n} (embedded)"),
        _ => name.clone(),
    };
    let route = route.map(|r| load_route(r, &w)).transpose()?;
    // Commands that do not generate worlds only drive the route (no exploration in W_1).
    let params = mapkeeper_closed_loop::SiteParams { check_exploration: need_areas, ..Default::default() };
    let site = mapkeeper_closed_loop::Site::resolve(&w, route.as_ref(), &origin, &params).context("--world")?;
    if need_areas {
        site.require_storage(&origin, &params).context("--world")?;
    }
    if site.planned_route {
        errln!(
            "mapkeeper: note: {origin} has no route: planned a {:.1} m patrol ({} waypoints)",
            site.route.length_m(),
            site.route.waypoints.len()
        );
    }
    if site.derived_areas {
        errln!("mapkeeper: note: {origin} has no storage areas: derived {}", site.storage.len());
    }
    Ok(Some((name, site)))
}

/// `--route FILE`, loaded and checked against `world` by the one rule of every command that
/// takes it (`validate`, `generate`, `recover`, `run`, `simulate`): every waypoint inside the
/// world and every leg, from the robot's start on, clear of its walls, columns, racks and items
/// by the route clearance (`SiteParams::route_clearance_m`). A refusal names `--route`, the file,
/// the waypoint and what is in the way.
pub fn load_route(path: &Path, world: &mapkeeper_sim::World) -> anyhow::Result<mapkeeper_sim::Route> {
    let route = mapkeeper_sim::Route::load(path).context("--route")?;
    let clearance = mapkeeper_closed_loop::SiteParams::default().route_clearance_m;
    mapkeeper_closed_loop::worlds::site::check_route(
        world,
        &route,
        &path.display().to_string(),
        "waypoints",
        clearance,
    )
    .map_err(|e| match e {
        // The message names the file and the waypoint; the generator's prefix says nothing here.
        mapkeeper_closed_loop::WorldsError::Generator(m) => anyhow::anyhow!(m),
        other => other.into(),
    })
    .context("--route")?;
    Ok(route)
}

/// W_1 of `--world` / `--route` (the default warehouse without them), with the recovery
/// parameters' tour, exploration route and storage areas taken from it; and its name. `site` is
/// what the flags give (`WorldArgs::load`), taken loaded so that this file and
/// `shared_args.rs` do not import each other.
pub fn site_world(
    site: Option<(String, mapkeeper_closed_loop::Site)>,
    recovery: &mut mapkeeper_scenario::RecoveryParams,
) -> anyhow::Result<(mapkeeper_sim::World, String)> {
    let Some((name, site)) = site else {
        return Ok((mapkeeper_sim::World::default_warehouse(), "warehouse".into()));
    };
    recovery.tour = site.route;
    recovery.exploration_route = site.exploration;
    recovery.generator.storage_areas = site.storage;
    recovery.validate().context("--world / --route")?;
    Ok((site.world, name))
}
