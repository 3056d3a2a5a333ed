//! TUM trajectory files (`t x y z qx qy qz qw`, one pose per line, `#` comments), the format the
//! `evo` tools read. Planar poses are written with z = 0 and a rotation about z.

use mapkeeper_grid::Pose2;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One timestamped planar pose.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StampedPose {
    /// Time, nanoseconds since the start of the run.
    pub stamp_ns: u64,
    /// The pose.
    pub pose: Pose2,
}

/// What went wrong reading or writing a TUM file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TumError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A line is malformed.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Formats poses as TUM text: time in seconds with 9 decimals (exact for integer nanoseconds),
/// positions and quaternion with 9 decimals.
pub fn format_tum(poses: &[StampedPose]) -> String {
    let mut s = String::with_capacity(poses.len() * 96 + 40);
    s.push_str("# t x y z qx qy qz qw\n");
    for p in poses {
        let (qz, qw) = ((p.pose.yaw / 2.0).sin(), (p.pose.yaw / 2.0).cos());
        let _ = writeln!(
            s,
            "{}.{:09} {:.9} {:.9} 0 0 0 {:.9} {:.9}",
            p.stamp_ns / 1_000_000_000,
            p.stamp_ns % 1_000_000_000,
            p.pose.x,
            p.pose.y,
            qz,
            qw
        );
    }
    s
}

/// Writes a TUM file atomically (temporary name, then rename).
pub fn write_tum(path: &Path, poses: &[StampedPose]) -> Result<(), TumError> {
    write_tum_with_comment(path, "", poses)
}

/// [`write_tum`] with extra `#` comment lines first (provenance: seed, inputs); `comment` may
/// hold several lines.
pub fn write_tum_with_comment(path: &Path, comment: &str, poses: &[StampedPose]) -> Result<(), TumError> {
    let mut text = String::new();
    for line in comment.lines() {
        text.push_str("# ");
        text.push_str(line);
        text.push('\n');
    }
    text.push_str(&format_tum(poses));
    mapkeeper_grid::write_atomic(path, text.as_bytes())
        .map_err(|source| TumError::Io { path: path.to_path_buf(), source })
}

/// Reads a TUM file: 8 numbers a line, `#` comment and blank lines skipped. The rotation must be
/// (close to) a rotation about z; times must be non-negative, finite and non-decreasing.
pub fn read_tum(path: &Path) -> Result<Vec<StampedPose>, TumError> {
    let text = std::fs::read(path).map_err(|source| TumError::Io { path: path.to_path_buf(), source })?;
    let text = String::from_utf8(text).map_err(|e| TumError::Parse {
        path: path.to_path_buf(),
        line: 1 + e.as_bytes()[..e.utf8_error().valid_up_to()].iter().filter(|&&b| b == b'\n').count(),
        message: "not valid UTF-8".into(),
    })?;
    parse_tum(&text, path)
}

/// Parses TUM text; `path` names the source in errors.
pub fn parse_tum(text: &str, path: &Path) -> Result<Vec<StampedPose>, TumError> {
    let err = |line: usize, message: String| TumError::Parse { path: path.to_path_buf(), line, message };
    let mut out: Vec<StampedPose> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = t.split_whitespace().collect();
        if fields.len() != 8 {
            return Err(err(line_no, format!("expected 8 fields 't x y z qx qy qz qw', found {}", fields.len())));
        }
        let mut v = [0.0f64; 8];
        for (k, (slot, f)) in v.iter_mut().zip(&fields).enumerate() {
            *slot = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(line_no, format!("field {} is not a finite number: '{f}'", k + 1)))?;
        }
        let [t_s, x, y, _z, qx, qy, qz, qw] = v;
        if !(0.0..1.8e10).contains(&t_s) {
            return Err(err(line_no, format!("time {t_s} s is negative or too large")));
        }
        let norm = (qx * qx + qy * qy + qz * qz + qw * qw).sqrt();
        if !(0.9..=1.1).contains(&norm) {
            return Err(err(line_no, format!("quaternion is not unit length (norm {norm:.3})")));
        }
        if (qx.abs() + qy.abs()) / norm > 1e-3 {
            return Err(err(line_no, "rotation is not about the z axis (qx, qy non-zero): not a planar pose".into()));
        }
        let stamp_ns = (t_s * 1e9).round() as u64;
        if out.last().is_some_and(|p| stamp_ns < p.stamp_ns) {
            return Err(err(line_no, "time goes backwards".into()));
        }
        let yaw = 2.0 * qz.atan2(qw);
        out.push(StampedPose { stamp_ns, pose: Pose2::new(x, y, mapkeeper_grid::wrap_angle(yaw)) });
    }
    Ok(out)
}

/// The pose at `stamp_ns`, linearly interpolated between the two nearest poses (yaw along the
/// shorter arc); clamped to the first or last pose outside the covered time. `None` if empty.
/// `poses` must be sorted by time. Same as [`interpolate_within`] with no gap limit.
pub fn interpolate(poses: &[StampedPose], stamp_ns: u64) -> Option<Pose2> {
    interpolate_within(poses, stamp_ns, u64::MAX)
}

/// The pose at `stamp_ns` from a time-sorted track, with a limit on how far poses may be from
/// it: a pose stamped exactly then (the last of several); else the linear interpolation of the
/// poses just before and after (yaw along the shorter arc) when they are at most
/// 2 × `max_gap_ns` apart; else the nearer of the two (the earlier on a tie) if it is within
/// `max_gap_ns`; else `None`. With `u64::MAX` the track is interpolated inside its time span
/// and clamped to its first or last pose outside it.
pub fn interpolate_within(poses: &[StampedPose], stamp_ns: u64, max_gap_ns: u64) -> Option<Pose2> {
    let k = poses.partition_point(|p| p.stamp_ns <= stamp_ns);
    let prev = k.checked_sub(1).and_then(|i| poses.get(i));
    if let Some(a) = prev
        && a.stamp_ns == stamp_ns
    {
        return Some(a.pose);
    }
    let next = poses.get(k);
    match (prev, next) {
        (Some(a), Some(b)) if b.stamp_ns - a.stamp_ns <= max_gap_ns.saturating_mul(2) => {
            let f = (stamp_ns - a.stamp_ns) as f64 / (b.stamp_ns - a.stamp_ns) as f64;
            let dyaw = mapkeeper_grid::angle_diff(b.pose.yaw, a.pose.yaw);
            Some(Pose2::new(
                a.pose.x + f * (b.pose.x - a.pose.x),
                a.pose.y + f * (b.pose.y - a.pose.y),
                mapkeeper_grid::wrap_angle(a.pose.yaw + f * dyaw),
            ))
        }
        _ => {
            let gap = |p: &StampedPose| p.stamp_ns.abs_diff(stamp_ns);
            [prev, next].into_iter().flatten().filter(|p| gap(p) <= max_gap_ns).min_by_key(|p| gap(p)).map(|p| p.pose)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let poses = vec![
            StampedPose { stamp_ns: 0, pose: Pose2::new(1.0, -2.0, 0.5) },
            StampedPose { stamp_ns: 80_000_000, pose: Pose2::new(1.1, -2.0, -3.0) },
            StampedPose { stamp_ns: 12_345_678_901, pose: Pose2::new(0.0, 0.0, std::f64::consts::PI) },
        ];
        let text = format_tum(&poses);
        assert!(text.contains("\n0.080000000 1.100000000 -2.000000000 0 0 0 "));
        let back = parse_tum(&text, Path::new("t.tum")).unwrap();
        assert_eq!(back.len(), 3);
        for (a, b) in poses.iter().zip(&back) {
            assert_eq!(a.stamp_ns, b.stamp_ns);
            assert!((a.pose.x - b.pose.x).abs() < 1e-9 && (a.pose.y - b.pose.y).abs() < 1e-9);
            assert!(mapkeeper_grid::angle_diff(a.pose.yaw, b.pose.yaw).abs() < 1e-8);
        }
    }

    #[test]
    fn errors_name_file_and_line() {
        let p = Path::new("poses.tum");
        for (text, want) in [
            ("0 1 2 0 0 0 0 1\n1 2 3\n", ":2: expected 8 fields"),
            ("# c\n0 1 nan 0 0 0 0 1\n", ":2: field 3"),
            ("0 1 2 0 0 0 0 5\n", ":1: quaternion"),
            ("0 1 2 0 0.7071 0 0 0.7071\n", ":1: rotation is not about the z axis"),
            ("2 1 2 0 0 0 0 1\n1 1 2 0 0 0 0 1\n", ":2: time goes backwards"),
            ("-1 1 2 0 0 0 0 1\n", ":1: time"),
        ] {
            let e = parse_tum(text, p).unwrap_err().to_string();
            assert!(e.starts_with("poses.tum") && e.contains(want), "{e} (wanted {want})");
        }
    }

    #[test]
    fn interpolation() {
        let poses = [
            StampedPose { stamp_ns: 100, pose: Pose2::new(0.0, 0.0, 3.0) },
            StampedPose { stamp_ns: 200, pose: Pose2::new(1.0, 2.0, -3.0) },
        ];
        assert_eq!(interpolate(&poses, 50), Some(poses[0].pose));
        assert_eq!(interpolate(&poses, 250), Some(poses[1].pose));
        let mid = interpolate(&poses, 150).unwrap();
        assert!((mid.x - 0.5).abs() < 1e-12 && (mid.y - 1.0).abs() < 1e-12);
        // Shorter arc across ±π.
        assert!((mid.yaw.abs() - std::f64::consts::PI).abs() < 1e-9);
        assert_eq!(interpolate(&[], 0), None);
    }
}
