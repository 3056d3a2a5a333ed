//! CC, MS and OPDF as every report gives them ([`Scores`]), and how they are computed and
//! averaged.

use crate::experiments::ExperimentError;
use crate::stats::mean;
use mapkeeper_grid::OccupancyGrid;
use mapkeeper_grid::metrics::{MapMetrics, MetricParams, map_metrics};
use serde::{Deserialize, Serialize};

pub(crate) fn mean_scores<'a>(v: impl Iterator<Item = &'a Scores> + Clone) -> Scores {
    Scores { cc: mean(v.clone().map(|s| s.cc)), ms: mean(v.clone().map(|s| s.ms)), opdf: mean(v.map(|s| s.opdf)) }
}

pub(crate) fn scores(map: &OccupancyGrid, g: &OccupancyGrid, m: &MetricParams) -> Result<Scores, ExperimentError> {
    Ok(Scores::from(map_metrics(map, g, m)?))
}

/// CC, MS and OPDF of one comparison, percent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    /// Cross-correlation.
    pub cc: f64,
    /// Map score.
    pub ms: f64,
    /// Occupied picture-distance function.
    pub opdf: f64,
}

impl From<MapMetrics> for Scores {
    fn from(m: MapMetrics) -> Self {
        Scores { cc: m.cc, ms: m.ms, opdf: m.opdf }
    }
}
