//! The flags of `validate` and `run` choosing the updater's pose source: `--poses
//! localiser|true|true+noise` and the noise model of `true+noise` (docs/evaluation.md, "The
//! updater's pose source").

use anyhow::Context;
use mapkeeper_closed_loop::UpdaterPoses;

/// Largest white-noise σ in x and y, metres: far beyond any localiser worth the name.
const MAX_SIGMA_XY_M: f64 = 10.0;
/// Largest yaw σ (white noise or bias), degrees.
const MAX_SIGMA_YAW_DEG: f64 = 180.0;
/// Largest time constant of the yaw bias, seconds (about 11.6 days: a constant bias).
const MAX_TAU_S: f64 = 1e6;

/// The updater's pose source and the noise model of `true+noise`.
#[derive(clap::Args, Debug, Clone)]
pub struct PoseArgs {
    /// The pose the updater is given: `localiser` (the chain localiser's estimate: the paper's
    /// setting), `true` (the simulator's true pose at every step, an oracle) or `true+noise` (the
    /// true pose plus white Gaussian noise in x, y and yaw and a slow yaw bias, a first-order
    /// Gauss–Markov process; --pose-noise-xy-m, --pose-noise-yaw-deg, --pose-bias-yaw-deg,
    /// --pose-bias-tau-s). The chain localiser and the baseline run, and are scored, either way;
    /// the source is recorded in the parameters and the reports (docs/evaluation.md, "The
    /// updater's pose source").
    #[arg(long, value_name = "localiser|true|true+noise", default_value = "localiser", value_parser = str::parse::<UpdaterPoses>)]
    pub poses: UpdaterPoses,
    /// With --poses true+noise: standard deviation of the white noise in x and in y, metres,
    /// 0 to 10 [default: 0.02].
    #[arg(long, value_name = "METRES", value_parser = super::real_in(0.0, MAX_SIGMA_XY_M, "m"), allow_hyphen_values = true)]
    pub pose_noise_xy_m: Option<f64>,
    /// With --poses true+noise: standard deviation of the white noise in yaw, degrees, 0 to 180
    /// [default: 0.5].
    #[arg(long, value_name = "DEGREES", value_parser = super::real_in(0.0, MAX_SIGMA_YAW_DEG, "deg"), allow_hyphen_values = true)]
    pub pose_noise_yaw_deg: Option<f64>,
    /// With --poses true+noise: stationary standard deviation of the yaw bias, degrees, 0 to
    /// 180 [default: 0.3].
    #[arg(long, value_name = "DEGREES", value_parser = super::real_in(0.0, MAX_SIGMA_YAW_DEG, "deg"), allow_hyphen_values = true)]
    pub pose_bias_yaw_deg: Option<f64>,
    /// With --poses true+noise: time constant of the yaw bias, seconds, > 0 and ≤ 1000000
    /// [default: 20].
    #[arg(long, value_name = "SECONDS", value_parser = super::positive_up_to(MAX_TAU_S, "s"), allow_hyphen_values = true)]
    pub pose_bias_tau_s: Option<f64>,
}

impl PoseArgs {
    /// The noise flags given, by name.
    fn noise_flags(&self) -> impl Iterator<Item = &'static str> {
        [
            (self.pose_noise_xy_m, "--pose-noise-xy-m"),
            (self.pose_noise_yaw_deg, "--pose-noise-yaw-deg"),
            (self.pose_bias_yaw_deg, "--pose-bias-yaw-deg"),
            (self.pose_bias_tau_s, "--pose-bias-tau-s"),
        ]
        .into_iter()
        .filter_map(|(v, flag)| v.map(|_| flag))
    }

    /// Whether any of the flags asks for more than the default (the chain localiser).
    pub fn is_set(&self) -> bool {
        !self.poses.is_localiser() || self.noise_flags().next().is_some()
    }

    /// The pose source the flags ask for; a noise flag without `--poses true+noise` is refused.
    pub fn updater_poses(&self) -> anyhow::Result<UpdaterPoses> {
        let UpdaterPoses::TrueNoise(mut noise) = self.poses else {
            if let Some(flag) = self.noise_flags().next() {
                anyhow::bail!("{flag} needs --poses true+noise (got --poses {})", self.poses.name());
            }
            return Ok(self.poses);
        };
        if let Some(v) = self.pose_noise_xy_m {
            noise.sigma_xy_m = v;
        }
        if let Some(v) = self.pose_noise_yaw_deg {
            noise.sigma_yaw_rad = v.to_radians();
        }
        if let Some(v) = self.pose_bias_yaw_deg {
            noise.yaw_bias_sigma_rad = v.to_radians();
        }
        if let Some(v) = self.pose_bias_tau_s {
            noise.yaw_bias_tau_s = v;
        }
        let poses = UpdaterPoses::TrueNoise(noise);
        poses
            .validate()
            .context("--pose-noise-xy-m / --pose-noise-yaw-deg / --pose-bias-yaw-deg / --pose-bias-tau-s")?;
        Ok(poses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Args as _;
    use mapkeeper_closed_loop::PoseNoise;

    /// The defaults the help states are the noise model's own.
    #[test]
    fn the_help_states_the_noise_models_defaults() {
        let cmd = PoseArgs::augment_args(clap::Command::new("t"));
        let help = |id: &str| {
            let arg = cmd.get_arguments().find(|a| a.get_id() == id).unwrap();
            arg.get_help().unwrap().to_string()
        };
        let d = PoseNoise::default();
        for (id, value) in [
            ("pose_noise_xy_m", d.sigma_xy_m),
            ("pose_noise_yaw_deg", d.sigma_yaw_rad.to_degrees()),
            ("pose_bias_yaw_deg", d.yaw_bias_sigma_rad.to_degrees()),
            ("pose_bias_tau_s", d.yaw_bias_tau_s),
        ] {
            let stated = format!("[default: {}]", (value * 1e9).round() / 1e9);
            assert!(help(id).ends_with(&stated), "{id}: {} does not end with {stated}", help(id));
        }
    }

    #[test]
    fn noise_flags_need_true_noise_and_set_the_model() {
        let args = PoseArgs {
            poses: "true+noise".parse().unwrap(),
            pose_noise_xy_m: Some(0.1),
            pose_noise_yaw_deg: Some(2.0),
            pose_bias_yaw_deg: None,
            pose_bias_tau_s: Some(5.0),
        };
        let want = PoseNoise {
            sigma_xy_m: 0.1,
            sigma_yaw_rad: 2f64.to_radians(),
            yaw_bias_tau_s: 5.0,
            ..PoseNoise::default()
        };
        assert_eq!(args.updater_poses().unwrap(), UpdaterPoses::TrueNoise(want));
        let plain = PoseArgs { poses: UpdaterPoses::True, ..args };
        assert!(
            plain.updater_poses().unwrap_err().to_string().starts_with("--pose-noise-xy-m needs --poses true+noise")
        );
    }
}
