//! The rows of `mapkeeper bench` and one repeat of measuring them.

use super::*;

/// The rows being measured: (name, unit, throughput unit, scale of the unit in seconds,
/// samples).
pub(super) struct Table {
    pub(super) reference: Vec<f64>,
    pub(super) rows: Vec<RowSpec>,
    /// Per localiser preset (in `LOCALISER_PRESETS` order), what it did on the scene.
    pub(super) filters: Vec<FilterWork>,
}

pub(super) struct RowSpec {
    pub(super) name: String,
    pub(super) unit: &'static str,
    pub(super) throughput_unit: &'static str,
    /// Seconds per `unit`'s unit (1e-3 for ms, 1e-9 for ns).
    pub(super) scale_s: f64,
    /// Per repeat: seconds per item.
    pub(super) per_item_s: Vec<f64>,
    /// Per repeat: the throughput.
    pub(super) throughput: Vec<f64>,
}

impl Table {
    pub(super) fn add(
        &mut self,
        name: String,
        unit: &'static str,
        throughput_unit: &'static str,
        scale_s: f64,
    ) -> usize {
        self.rows.push(RowSpec {
            name,
            unit,
            throughput_unit,
            scale_s,
            per_item_s: Vec::new(),
            throughput: Vec::new(),
        });
        self.rows.len() - 1
    }

    pub(super) fn push(&mut self, key: usize, per_item_s: f64, throughput: f64) {
        self.rows[key].per_item_s.push(per_item_s);
        self.rows[key].throughput.push(throughput);
    }
}

/// The median of a row's samples (0 for none; every row has one per repeat).
pub(super) fn median(v: &[f64]) -> f64 {
    mapkeeper_scenario::stats::median(v.to_vec()).unwrap_or(0.0)
}

/// The rows of the table, in order.
pub(super) struct Keys {
    pub(super) sim: usize,
    pub(super) localisers: Vec<usize>,
    pub(super) updaters: Vec<usize>,
    pub(super) fresh_map: usize,
    pub(super) traversal: usize,
    pub(super) global: usize,
    pub(super) lost_second: usize,
    /// (CPU row, wall row) per closed-loop preset.
    pub(super) loops: Vec<(usize, usize)>,
}

/// The closed loop's presets: the default validation's.
pub(super) const LOOP_PRESETS: [&str; 2] = ["paper", "mapkeeper"];

/// `fresh_stride`: how often the validation integrates its fresh map (every n-th step).
pub(super) fn table_rows(table: &mut Table, with_loop: bool, fresh_stride: u32) -> Keys {
    let sim = table.add("simulator: one lidar step (physics, agents, both lidars)".into(), "ms", "steps/s", 1e-3);
    let localisers = LOCALISER_PRESETS
        .iter()
        .map(|n| table.add(format!("localiser `{n}`: one frame (both lidars)"), "ms", "frames/s", 1e-3))
        .collect();
    let updaters = PRESET_NAMES
        .iter()
        .map(|n| table.add(format!("updater `{n}`: one processed dual-S300 step"), "ms", "steps/s", 1e-3))
        .collect();
    let fresh_map = table.add(
        format!("fresh map: one dual-S300 step integrated (log-odds mapper; the validation integrates one step in {fresh_stride})"),
        "ms",
        "steps/s",
        1e-3,
    );
    let traversal = table.add("grid traversal: `RayCaster::cast`, W_1 truth, 30 m".into(), "ns/ray", "M rays/s", 1e-9);
    let global = table.add(
        "pose recovery when Lost, `mapkeeper`, kidnapped 5 m + half a turn: one attempt (local, then global search)"
            .into(),
        "ms",
        "attempts/s",
        1e-3,
    );
    let lost_second = table.add(
        "pose recovery while Lost, `mapkeeper`: one second Lost where nothing fits, driving on (the check every step, \
         a refused attempt every 0.5 s judged on up to four views)"
            .into(),
        "ms",
        "× real time",
        1e-3,
    );
    let loops = if with_loop {
        LOOP_PRESETS
            .iter()
            .map(|n| {
                let cpu =
                    table.add(format!("closed loop `{n}` + amcl, one world: CPU per step"), "ms", "× real time", 1e-3);
                let wall =
                    table.add(format!("closed loop `{n}` + amcl, one world: wall per step"), "ms", "× real time", 1e-3);
                (cpu, wall)
            })
            .collect()
    } else {
        Vec::new()
    };
    Keys { sim, localisers, updaters, fresh_map, traversal, global, lost_second, loops }
}

/// One repeat of every component row (not the loop).
pub(super) fn measure_components(
    scene: &Scene,
    caster: &RayCaster,
    seed: u64,
    table: &mut Table,
    keys: &Keys,
) -> anyhow::Result<()> {
    let n = scene.steps.len();
    let (t, recorded) = timed(|| simulate(&scene.w2, &scene.route, &scene.params, seed, n));
    recorded?;
    table.push(keys.sim, t / n as f64, n as f64 / t);
    for (i, (&key, name)) in keys.localisers.iter().zip(LOCALISER_PRESETS).enumerate() {
        let (t, work) = timed(|| run_localiser(scene, name, seed));
        table.filters[i].pool(work?);
        table.push(key, t / n as f64, n as f64 / t);
    }
    for (&key, name) in keys.updaters.iter().zip(PRESET_NAMES) {
        let (t, processed) = timed(|| run_updater(scene, name));
        let processed = processed?.max(1);
        table.push(key, t / processed as f64, processed as f64 / t);
    }
    let (t, steps) = timed(|| run_fresh_map(scene));
    let steps = steps?.max(1);
    table.push(keys.fresh_map, t / steps as f64, steps as f64 / t);
    let (t, (rays, _)) = timed(|| run_traversal(caster, scene));
    table.push(keys.traversal, t / rays as f64, rays as f64 / t / 1e6);
    let mut up = MapUpdater::new(scene.map.clone(), UpdaterParams::mapkeeper())?;
    let (t, attempts) = timed(|| run_global_recovery(scene, &mut up));
    let attempts = attempts?.max(1);
    table.push(keys.global, t / attempts as f64, attempts as f64 / t);
    let mut up = MapUpdater::new(scene.map.clone(), UpdaterParams::mapkeeper())?;
    let (t, lost) = timed(|| run_lost_seconds(scene, &mut up));
    let (span_s, _) = lost?;
    table.push(keys.lost_second, t / span_s, span_s / t);
    Ok(())
}
