//! The flags of `experiment sensor-realism` laid over its parameters.

use super::Args;
use mapkeeper_scenario::experiments::validation::sensor_realism::SensorRealismParams;

/// The command-line overrides of the parameter file.
pub(super) fn apply_flags(args: &Args, p: &mut SensorRealismParams) {
    if let Some(v) = args.worlds {
        p.worlds = v;
    }
    if let Some(v) = args.seeds {
        p.seeds = v;
    }
    if let Some(v) = args.seed {
        p.first_seed = v;
    }
    if let Some(v) = &args.preset {
        p.preset.clone_from(v);
    }
    if let Some(v) = args.route_length {
        p.route_length_m = v;
    }
    if let Some(v) = &args.configs {
        p.configs = v.iter().map(|c| c.trim().to_string()).collect();
    }
}
