//! Robot files: the robot's body and its lidars (model by name or inline, mount, upside-down
//! flag) as a TOML file (`docs/robot-format.md`), validated on load with errors that name the
//! file, the entry and the problem.

use crate::error::SimError;
use crate::lidar::{LIDAR_MODELS, LidarNoise, LidarParams};
use crate::robot::RobotParams;
use crate::sim::SimParams;
use crate::world::parse_toml;
use mapkeeper_grid::Pose2;
use serde::Deserialize;
use std::path::Path;

/// The `format` value of a robot file.
pub const ROBOT_FORMAT: &str = "mapkeeper-robot";

/// The robots embedded in the binary (`robots/*.toml`), by name: the Summit-XL Steel with its
/// S300 pair mounted upside down, with the lab's Hokuyo UST-20LX pair, and one generic lidar.
pub const EMBEDDED_ROBOTS: [&str; 3] = ["summit-xl-steel-s300", "summit-xl-steel-ust20lx", "generic-lidar"];

/// A robot file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobotFile {
    format: String,
    version: u32,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    body: RobotParams,
    #[serde(default)]
    lidars: Vec<RawLidar>,
}

/// One `[[lidars]]` entry as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLidar {
    model: toml::Value,
    x: f64,
    y: f64,
    yaw_deg: f64,
    #[serde(default)]
    upside_down: bool,
    #[serde(default)]
    phase_offset_s: f64,
    #[serde(default)]
    noise: Option<LidarNoise>,
}

/// A generic lidar model: every field given by the user (`model = { … }`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GenericModel {
    fov_deg: f64,
    resolution_deg: f64,
    range_min_m: f64,
    range_max_m: f64,
    rate_hz: f64,
    sigma_m: f64,
    quantisation_m: f64,
    dropout_probability: f64,
    spurious_probability: f64,
    spurious_max_m: f64,
}

impl GenericModel {
    /// The lidar, symmetric about its x axis, at `mount`.
    fn lidar(&self, mount: Pose2) -> Result<LidarParams, String> {
        for (name, v) in [("fov_deg", self.fov_deg), ("resolution_deg", self.resolution_deg)] {
            if !(v.is_finite() && v > 0.0 && v <= 360.0) {
                return Err(format!("{name} must be in (0, 360], got {v}"));
            }
        }
        let steps = self.fov_deg / self.resolution_deg;
        if (steps - steps.round()).abs() > 1e-6 * steps.max(1.0)
            || steps.round() + 1.0 > mapkeeper_sensor::MAX_BEAMS as f64
        {
            return Err(format!(
                "fov_deg {} is not a whole number of resolution_deg {} steps (at most {} beams)",
                self.fov_deg,
                self.resolution_deg,
                mapkeeper_sensor::MAX_BEAMS
            ));
        }
        Ok(LidarParams {
            lidar_in_robot: mount,
            angle_min_rad: (-self.fov_deg / 2.0).to_radians(),
            angle_increment_rad: self.resolution_deg.to_radians(),
            beams: steps.round() as usize + 1,
            range_min_m: self.range_min_m,
            range_max_m: self.range_max_m,
            rate_hz: self.rate_hz,
            phase_offset_s: 0.0,
            noise: LidarNoise {
                sigma_m: self.sigma_m,
                quantisation_m: self.quantisation_m,
                dropout_probability: self.dropout_probability,
                spurious_probability: self.spurious_probability,
                spurious_max_m: self.spurious_max_m,
            },
            upside_down: false,
        })
    }
}

/// A robot: body and lidars, read from a robot file.
///
/// ```
/// use mapkeeper_sim::{RobotFile, SimParams};
/// let text = r#"
/// format = "mapkeeper-robot"
/// version = 1
/// [[lidars]]
/// model = "hokuyo_ust20lx"
/// x = 0.3
/// y = 0.0
/// yaw_deg = 0
/// upside_down = true
/// "#;
/// let robot = RobotFile::from_toml_str(text, "r.toml").unwrap();
/// let mut p = SimParams::default();
/// robot.apply(&mut p);
/// assert_eq!(p.lidars.len(), 1);
/// assert!(p.lidars[0].upside_down && p.lidars[0].beams == 1081);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RobotFile {
    /// Its name (default: the file's).
    pub name: String,
    /// Body, drive limits and path follower.
    pub robot: RobotParams,
    /// The lidars, in `lidar_id` order.
    pub lidars: Vec<LidarParams>,
}

impl RobotFile {
    /// Parses and validates a robot file's text; `origin` names it in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<RobotFile, SimError> {
        let raw: RawRobotFile = parse_toml(text, origin)?;
        let bad = |entry: String, problem: String| SimError::Invalid { origin: origin.to_string(), entry, problem };
        if raw.format != ROBOT_FORMAT {
            return Err(bad("format".into(), format!("is \"{}\", expected \"{ROBOT_FORMAT}\"", raw.format)));
        }
        if raw.version != 1 {
            return Err(bad("version".into(), format!("version {} is not supported (expected 1)", raw.version)));
        }
        raw.body.validate().map_err(|e| bad("body".into(), e.to_string()))?;
        if raw.lidars.is_empty() {
            return Err(bad("lidars".into(), "a robot needs at least one [[lidars]] entry".into()));
        }
        let lidars = raw
            .lidars
            .iter()
            .enumerate()
            .map(|(i, l)| lidar_of(l).map_err(|(place, e)| bad(format!("lidars[{i}]{place}"), e)))
            .collect::<Result<Vec<_>, _>>()?;
        let name = raw.name.unwrap_or_else(|| {
            Path::new(origin).file_stem().map_or_else(|| origin.to_string(), |s| s.to_string_lossy().into_owned())
        });
        Ok(RobotFile { name, robot: raw.body, lidars })
    }

    /// An embedded robot by name ([`EMBEDDED_ROBOTS`], the files of `robots/`).
    pub fn embedded(name: &str) -> Option<RobotFile> {
        let text = match name {
            "summit-xl-steel-s300" => include_str!("../../../robots/summit-xl-steel-s300.toml"),
            "summit-xl-steel-ust20lx" => include_str!("../../../robots/summit-xl-steel-ust20lx.toml"),
            "generic-lidar" => include_str!("../../../robots/generic-lidar.toml"),
            _ => return None,
        };
        match RobotFile::from_toml_str(text, &format!("robots/{name}.toml (embedded)")) {
            Ok(r) => Some(r),
            // The embedded files are checked by the crate's tests; this cannot happen in a release.
            Err(e) => panic!("an embedded robot file is invalid: {e}"),
        }
    }

    /// A robot named on the command line: an embedded robot's name, else a robot file.
    pub fn named_or_load(arg: &Path) -> Result<RobotFile, SimError> {
        match arg.to_str().and_then(RobotFile::embedded) {
            Some(r) => Ok(r),
            None => RobotFile::load(arg),
        }
    }

    /// Reads a robot file.
    pub fn load(path: &Path) -> Result<RobotFile, SimError> {
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io { path: path.to_path_buf(), source })?;
        RobotFile::from_toml_str(&text, &path.display().to_string())
    }

    /// Puts the robot and its lidars into `params` (the rest of it unchanged).
    pub fn apply(&self, params: &mut SimParams) {
        params.robot = self.robot.clone();
        params.lidars = self.lidars.clone();
    }
}

/// The lidar of one entry, or the place within the entry (e.g. `.model`) and the problem.
fn lidar_of(l: &RawLidar) -> Result<LidarParams, (&'static str, String)> {
    for (place, v) in [(".x", l.x), (".y", l.y), (".yaw_deg", l.yaw_deg)] {
        if !v.is_finite() {
            return Err((place, format!("must be finite, got {v}")));
        }
    }
    let mount = Pose2::new(l.x, l.y, l.yaw_deg.to_radians());
    let mut lidar = match &l.model {
        toml::Value::String(name) => LidarParams::model(name, mount).ok_or_else(|| {
            (".model", format!("unknown lidar model '{name}' (known: {}, or an inline table)", LIDAR_MODELS.join(", ")))
        })?,
        toml::Value::Table(t) => {
            let g = GenericModel::deserialize(toml::Value::Table(t.clone()))
                .map_err(|e| (".model", format!("inline model: {}", e.message().trim())))?;
            g.lidar(mount).map_err(|e| (".model", e))?
        }
        other => {
            return Err((".model", format!("must be a model name or an inline table, got a {}", other.type_str())));
        }
    };
    lidar.upside_down = l.upside_down;
    lidar.phase_offset_s = l.phase_offset_s;
    if let Some(n) = &l.noise {
        lidar.noise = n.clone();
    }
    lidar.validate().map_err(|e| ("", e.to_string()))?;
    Ok(lidar)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "format = \"mapkeeper-robot\"\nversion = 1\n";

    fn err(body: &str) -> String {
        RobotFile::from_toml_str(&format!("{HEAD}{body}"), "bot.toml").unwrap_err().to_string()
    }

    #[test]
    fn summit_with_upside_down_s300s_and_generic_model() {
        let text = format!(
            "{HEAD}name = \"summit\"\n[body]\nlength_m = 0.75\n\n[[lidars]]\nmodel = \"sick_s300\"\nx = 0.2865\n\
             y = -0.2089\nyaw_deg = -45\nupside_down = true\n\n[[lidars]]\nx = -0.2865\ny = 0.2089\nyaw_deg = 135\n\
             model = {{ fov_deg = 240, resolution_deg = 0.5, range_min_m = 0.1, range_max_m = 10, rate_hz = 10, \
             sigma_m = 0.02, quantisation_m = 0.001, dropout_probability = 0, spurious_probability = 0, \
             spurious_max_m = 1 }}\n"
        );
        let r = RobotFile::from_toml_str(&text, "summit.toml").unwrap();
        assert_eq!(r.name, "summit");
        assert!(r.lidars[0].upside_down);
        assert_eq!(r.lidars[0].beams, 541);
        assert!((r.lidars[0].lidar_in_robot.yaw + std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        let g = &r.lidars[1];
        assert_eq!(g.beams, 481);
        assert!((g.angle_min_rad + 120f64.to_radians()).abs() < 1e-12 && g.rate_hz == 10.0 && !g.upside_down);
    }

    #[test]
    fn every_embedded_robot_parses_and_names_resolve_before_files() {
        for name in EMBEDDED_ROBOTS {
            let r = RobotFile::embedded(name).unwrap();
            assert_eq!(r.name, name);
            assert_eq!(RobotFile::named_or_load(Path::new(name)).unwrap(), r);
        }
        let lab = RobotFile::embedded("summit-xl-steel-ust20lx").unwrap();
        assert!(lab.lidars.len() == 2 && lab.lidars.iter().all(|l| l.beams == 1081 && l.rate_hz == 40.0));
        assert!(RobotFile::embedded("nope").is_none());
        let e = RobotFile::named_or_load(Path::new("/nonexistent/bot.toml")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/bot.toml"), "{e}");
    }

    #[test]
    fn bad_files_name_the_file_entry_and_problem() {
        let e = err("[[lidars]]\nmodel = \"velodyne\"\nx = 0\ny = 0\nyaw_deg = 0\n");
        assert!(e.starts_with("bot.toml: lidars[0].model: unknown lidar model 'velodyne'"), "{e}");
        let e = err("[[lidars]]\nmodel = \"sick_s300\"\nx = 0\ny = nan\nyaw_deg = 0\n");
        assert!(e.starts_with("bot.toml: lidars[0].y: must be finite"), "{e}");
        let e = err("[[lidars]]\nmodel = { fov_deg = 270 }\nx = 0\ny = 0\nyaw_deg = 0\n");
        assert!(e.contains("lidars[0].model: inline model: missing field"), "{e}");
        let e = err(
            "[[lidars]]\nx = 0\ny = 0\nyaw_deg = 0\nmodel = { fov_deg = 270, resolution_deg = 0.7, range_min_m = 0.1, \
             range_max_m = 10, rate_hz = 10, sigma_m = 0, quantisation_m = 0, dropout_probability = 0, \
             spurious_probability = 0, spurious_max_m = 1 }\n",
        );
        assert!(e.contains("lidars[0].model: fov_deg 270 is not a whole number"), "{e}");
        let e = err("[[lidars]]\nmodel = 3\nx = 0\ny = 0\nyaw_deg = 0\n");
        assert!(e.contains("lidars[0].model: must be a model name or an inline table"), "{e}");
        let e = err("[[lidars]]\nmodel = \"sick_s300\"\nx = 0\ny = 0\nyaw_deg = 0\nphase_offset_s = -1\n");
        assert!(e.starts_with("bot.toml: lidars[0]: phase_offset_s"), "{e}");
        // A first scan 31,710 years late would overflow the nanosecond schedule.
        let e = err("[[lidars]]\nmodel = \"sick_s300\"\nx = 0\ny = 0\nyaw_deg = 0\nphase_offset_s = 1e12\n");
        assert!(e.starts_with("bot.toml: lidars[0]: phase_offset_s must be in [0, 3600] s, got 1000000000000"), "{e}");
        // One scan in 3,000 years: the period would not fit the schedule either.
        let e = err(
            "[[lidars]]\nx = 0\ny = 0\nyaw_deg = 0\nmodel = { fov_deg = 270, resolution_deg = 0.5, range_min_m = 0.1, \
             range_max_m = 10, rate_hz = 1e-11, sigma_m = 0, quantisation_m = 0, dropout_probability = 0, \
             spurious_probability = 0, spurious_max_m = 1 }\n",
        );
        assert!(e.contains("lidars[0]") && e.contains("rate_hz must be in [0.01, 1000], got 0.00000000001"), "{e}");
        let e = err("[body]\nwidth_m = 0\n[[lidars]]\nmodel = \"sick_s300\"\nx = 0\ny = 0\nyaw_deg = 0\n");
        assert!(e.starts_with("bot.toml: body: width_m"), "{e}");
        let e = err("");
        assert!(e.starts_with("bot.toml: lidars: a robot needs"), "{e}");
        let e = err("[[lidars]]\nmodel = \"sick_s300\"\nx = 0\ny = 0\nyaw_deg = 0\nroll = 1\n");
        assert!(e.starts_with("bot.toml: line ") && e.contains("roll"), "{e}");
        let e = RobotFile::from_toml_str("format = \"robot\"\nversion = 1\n", "b.toml").unwrap_err().to_string();
        assert!(e.starts_with("b.toml: format:"), "{e}");
        let e = RobotFile::load(Path::new("/nonexistent/bot.toml")).unwrap_err().to_string();
        assert!(e.starts_with("/nonexistent/bot.toml: "), "{e}");
    }
}
