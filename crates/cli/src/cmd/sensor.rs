//! The robot and sensor flags shared by `simulate`, `run` and `validate`: `--robot FILE`
//! (docs/robot-format.md), `--sensor-profile ideal|realistic` and `--sensor-effects LIST`
//! (docs/simulator.md, Sensor realism).

use anyhow::Context;
use mapkeeper_sim::{RobotFile, SensorEffect, SensorRealism, SimParams};
use std::path::PathBuf;

/// The robot file and the sensor-realism switches.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SensorArgs {
    /// Robot: an embedded robot's name (summit-xl-steel-s300, summit-xl-steel-ust20lx,
    /// generic-lidar: the files of robots/) or a robot file (body and lidars: model by name or
    /// inline, mount x/y/yaw, upside-down flag; docs/robot-format.md). Default: the Summit-XL
    /// Steel with two SICK S300, their mirror folded into the mount.
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: Option<PathBuf>,
    /// Sensor realism profile: `ideal` (the default: exact geometry plus the lidars' noise
    /// model) or `realistic` (every effect of --sensor-effects on).
    #[arg(long, value_name = "ideal|realistic", conflicts_with = "sensor_effects")]
    pub sensor_profile: Option<String>,
    /// Exactly these sensor-realism effects on (comma-separated): mixed-pixels, range-noise,
    /// motion-distortion, unsync, extrinsic-error, latency, legs.
    #[arg(long, value_name = "E1,E2,…", value_delimiter = ',')]
    pub sensor_effects: Option<Vec<String>>,
}

impl SensorArgs {
    /// Whether any of the flags is given.
    pub fn is_set(&self) -> bool {
        self.robot.is_some() || self.sensor_profile.is_some() || self.sensor_effects.is_some()
    }

    /// The realism the flags ask for, if they ask for any.
    pub fn realism(&self) -> anyhow::Result<Option<SensorRealism>> {
        if let Some(p) = &self.sensor_profile {
            return Ok(Some(SensorRealism::profile(p).map_err(anyhow::Error::msg).context("--sensor-profile")?));
        }
        let Some(list) = &self.sensor_effects else { return Ok(None) };
        let effects = list
            .iter()
            .map(|e| SensorEffect::parse(e.trim()))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)
            .context("--sensor-effects")?;
        Ok(Some(SensorRealism::with_effects(&effects)))
    }

    /// Puts the robot file (if any) and the realism (if asked for) into `params`; checked
    /// before anything runs.
    pub fn apply(&self, params: &mut SimParams) -> anyhow::Result<()> {
        let realism = self.realism()?;
        if let Some(path) = &self.robot {
            RobotFile::named_or_load(path).context("--robot")?.apply(params);
        }
        if let Some(r) = realism {
            params.realism = r;
        }
        params.validate().context("--robot / --sensor-profile / --sensor-effects")?;
        Ok(())
    }
}
