//! How far an odometry drifts from a log's reference poses per metre travelled: over each stretch
//! of about `stretch_m` of the reference's path (from each reference pose to the first one at
//! least that far along), the error of the odometry's relative pose against the reference's,
//! divided by the stretch's length. `mapkeeper convert` prints it for any log with reference
//! poses, so the scan-made odometry and a log's own are measured alike
//! (`docs/real-data.md`, "Logs with scans only").

use mapkeeper_grid::{Pose2, wrap_angle};
use mapkeeper_sensor::{StampedPose, interpolate};

/// The drift of an odometry against a reference, per metre of the reference's path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryDrift {
    /// The stretch length asked for, metres.
    pub stretch_m: f64,
    /// Stretches measured.
    pub stretches: usize,
    /// The reference's path over the odometry's time span, metres.
    pub path_m: f64,
    /// Mean position error per metre, centimetres per metre.
    pub mean_cm_per_m: f64,
    /// Its 95th percentile.
    pub p95_cm_per_m: f64,
    /// Mean yaw error per metre, degrees per metre.
    pub mean_deg_per_m: f64,
    /// Its 95th percentile.
    pub p95_deg_per_m: f64,
}

impl std::fmt::Display for OdometryDrift {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.1} cm/m (p95 {:.1}) and {:.2} deg/m (p95 {:.2}) over {} stretches of {} m ({:.0} m of path)",
            self.mean_cm_per_m,
            self.p95_cm_per_m,
            self.mean_deg_per_m,
            self.p95_deg_per_m,
            self.stretches,
            self.stretch_m,
            self.path_m
        )
    }
}

/// The drift of `odometry` (interpolated at the reference's stamps) against `reference` over
/// stretches of `stretch_m`; `None` without a stretch (too little of the reference within the
/// odometry's time span, or a stretch that is not positive and finite).
pub fn odometry_drift(odometry: &[StampedPose], reference: &[StampedPose], stretch_m: f64) -> Option<OdometryDrift> {
    if !(stretch_m.is_finite() && stretch_m > 0.0) {
        return None;
    }
    let pairs: Vec<(Pose2, Pose2)> =
        reference.iter().filter_map(|r| interpolate(odometry, r.stamp_ns).map(|o| (o, r.pose))).collect();
    let mut along = Vec::with_capacity(pairs.len());
    let mut total = 0.0;
    for (k, (_, r)) in pairs.iter().enumerate() {
        if k > 0 {
            total += pairs[k - 1].1.distance(r);
        }
        along.push(total);
    }
    let (mut position, mut yaw) = (Vec::new(), Vec::new());
    let mut j = 0;
    for i in 0..pairs.len() {
        j = j.max(i);
        while j < pairs.len() && along[j] - along[i] < stretch_m {
            j += 1;
        }
        let Some(end) = pairs.get(j) else { break };
        let length = along[j] - along[i];
        let made = pairs[i].0.between(&end.0);
        let real = pairs[i].1.between(&end.1);
        position.push(100.0 * (made.x - real.x).hypot(made.y - real.y) / length);
        yaw.push(wrap_angle(made.yaw - real.yaw).abs().to_degrees() / length);
    }
    if position.is_empty() {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let p95 = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * 0.95) as usize]
    };
    Some(OdometryDrift {
        stretch_m,
        stretches: position.len(),
        path_m: total,
        mean_cm_per_m: mean(&position),
        p95_cm_per_m: p95(position.clone()),
        mean_deg_per_m: mean(&yaw),
        p95_deg_per_m: p95(yaw),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(poses: impl Iterator<Item = Pose2>) -> Vec<StampedPose> {
        poses.enumerate().map(|(k, pose)| StampedPose { stamp_ns: k as u64 * 1_000_000, pose }).collect()
    }

    #[test]
    fn an_odometry_short_by_a_tenth_drifts_ten_centimetres_a_metre_and_a_true_one_none() {
        // 10 m straight ahead in 0.1 m steps; the odometry counts 0.09 m a step, in its own frame.
        let reference = track((0..=100).map(|k| Pose2::new(2.0 + 0.1 * k as f64, 1.0, 0.0)));
        let short = track((0..=100).map(|k| Pose2::new(0.09 * k as f64, 0.0, 0.0)));
        let d = odometry_drift(&short, &reference, 1.0).unwrap();
        assert_eq!(d.stretches, 91);
        assert!((d.mean_cm_per_m - 10.0).abs() < 1e-6 && (d.p95_cm_per_m - 10.0).abs() < 1e-6, "{d}");
        assert!(d.mean_deg_per_m.abs() < 1e-9 && (d.path_m - 10.0).abs() < 1e-9);
        let exact = track((0..=100).map(|k| Pose2::new(0.1 * k as f64, 0.0, 0.0)));
        assert!(odometry_drift(&exact, &reference, 1.0).unwrap().mean_cm_per_m < 1e-6);
        // Longer than the path, empty, or not a length: nothing to say.
        assert_eq!(odometry_drift(&exact, &reference, 20.0), None);
        assert_eq!(odometry_drift(&[], &reference, 1.0), None);
        assert_eq!(odometry_drift(&exact, &reference, f64::NAN), None);
    }
}
