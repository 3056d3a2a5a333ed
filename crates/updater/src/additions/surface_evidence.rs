//! Surface evidence across worlds, weighted by trust (a `mapkeeper` addition, issue 53).
//!
//! The paper's classifier cannot see what happens within D_th(z) (0.15-0.30 m) of `M_{i-1}`'s
//! structure: a beam that ends there "agrees with the map", so it never votes. Three kinds of
//! error live in that band and nothing fixed them:
//! - **`M_1`'s own errors.** The survey's log-odds mapper makes faces a cell too thick (a cell
//!   with a third of its beams ending in it is occupied), leaves single phantom cells and gaps;
//!   the oracle `M*_i` and a fresh map at good poses draw the face where it is.
//! - **Items moved a little**, within a storage area: the new face lies within D_th of the old
//!   one, so the item is neither added where it is nor removed where it was.
//! - **Eroded faces** (the third release's scars): a wall face cell freed by a pose error that
//!   a beam ends on again.
//!
//! **On in the preset `mapkeeper-evidence` only**, with registration to cell centres (with the
//! flat-bottomed registration faces migrate a cell at a time). Better than `mapkeeper` in the
//! simulator, worse on the real logs, so not the default: `docs/updater.md`, "Surface evidence".
//!
//! This module keeps, per cell of that band, the evidence every trusted step gave about it,
//! carried from world to world with `M_i` (in [`crate::StructureMemory`]), and decides the cell
//! by the share of its weighted observations that ended in it: the estimator of a fresh map
//! (a cell is occupied iff the surface passes through it, i.e. beams that reach it end in it),
//! with the threshold where it belongs (half, not the mapper's third) and the memory of many
//! runs. The rules, each with the failure it prevents:
//!
//! 1. **Only the band.** A beam gives evidence on the cell where it ends (a hit) and on the cells
//!    it crossed in its last `band_m` (passes); the rest of the ray is the classifier's. New
//!    obstacles and removed items far from what the beam hit stay with the paper's evaluators
//!    and buffers.
//! 2. **Trust.** A beam's observation weighs `1 − (σ/σ_max)²`, σ the spread of its end point
//!    from the step's pose uncertainty (registration's fit, else the localiser's covariance:
//!    σ_xy, and σ_yaw times the range); a beam whose end may lie more than `max_sigma_m` off
//!    gives none, and a step with no reported uncertainty gives none unless
//!    `trust_unreported_pose`. Steps that registration refused, that the check did not pass or
//!    that the gate held write nothing, as for the paper's cells update. Prevents: far beams
//!    under a yaw error moving faces.
//! 3. **One surface, met steeply.** The end points of the beam and its two neighbours on each
//!    side are fitted with a line; more than `planarity_m` RMS off it (a corner, a leg, an
//!    edge), or met at less than `min_incidence_deg`, and the beam gives nothing. The hit goes
//!    to the cell where the beam meets the line (the range noise of one beam averaged over
//!    five), and a crossed cell counts as free only if it lies wholly in front of the line (its
//!    centre further than its half-extent along the normal, plus `surface_margin_m`): a beam
//!    crossing a face cell before it ends, at a shallow incidence, says nothing about it.
//!    Prevents: a robot driving along a wall thinning it, and the survey's mapper's bias (a
//!    cell a third of whose beams end in it drawn occupied).
//! 4. **One flag per cell per step**, as the paper's flags: the cell's observations of one step
//!    (both lidars, every beam) count once, as a hit if at least as many ended in it as crossed
//!    it, with the largest weight among them. Prevents: one standing scan outvoting many runs.
//! 5. **Decide by share, with hysteresis and enough evidence.** With at least `min_weight` of
//!    weighted flags, a cell becomes occupied when the hit share reaches `occupied_share`
//!    (free and unknown cells 8-adjacent to an occupied cell of `M_{i-1}` only, and with
//!    `grow_established` off only beside young structure: a face grows by a cell per world,
//!    never a new obstacle in open space, so a person's trail cannot crawl across an aisle),
//!    free when it falls to `free_share`. Between the two the cell keeps its state.
//! 6. **Bounded memory that forgets.** Each record holds two weights; when their sum exceeds
//!    `max_weight` both are scaled down, so old evidence fades at the rate new evidence comes
//!    (a cell seen free from many good poses over several worlds goes even if it was structure;
//!    a cell hit again and again stays however old). A record is created only when an
//!    observation disagrees with the cell's state in `M_i`, and dropped when the record agrees
//!    decisively with the state (share ≥ `1 − drop_margin` for an occupied cell, ≤
//!    `drop_margin` for a free one): memory grows with the cells in question, not the map.

pub use crate::additions::structure_memory::CellEvidence;
use crate::paper::beam_classifier::{Beam, BeamClass, LidarFrame};
use crate::paper::cell_update::CellChange;
pub use crate::params::evidence::EvidenceParams;
use crate::support::cell_buffers::TileHasher;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse_indexed};
use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::ops::ControlFlow;

type Records = HashMap<u32, CellEvidence, BuildHasherDefault<TileHasher>>;

/// One observation of the step: cell index, weight, whether the beam ended in the cell.
#[derive(Clone, Copy, Debug)]
struct Observation {
    index: u32,
    weight: f32,
    hit: bool,
}

/// The surface evidence of a run: the records carried in, updated by each written step.
#[derive(Clone, Debug, Default)]
pub struct SurfaceEvidence {
    records: Records,
    observations: Vec<Observation>,
}

impl SurfaceEvidence {
    /// The evidence carried in with `M_{i-1}` (records sorted by index, as stored).
    pub fn from_records(records: &[(u32, CellEvidence)]) -> Self {
        Self { records: records.iter().copied().collect(), observations: Vec::new() }
    }

    /// The records to carry to the next world, sorted by cell index.
    pub fn records(&self) -> Vec<(u32, CellEvidence)> {
        let mut out: Vec<(u32, CellEvidence)> = self.records.iter().map(|(&k, &v)| (k, v)).collect();
        out.sort_unstable_by_key(|r| r.0);
        out
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether there is no record.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Heap bytes of the records (the change state) and of the step's scratch.
    pub fn state_bytes(&self) -> usize {
        self.records.capacity() * (size_of::<u32>() + size_of::<CellEvidence>() + 1)
    }

    /// Heap bytes of the per-step scratch.
    pub fn scratch_bytes(&self) -> usize {
        self.observations.capacity() * size_of::<Observation>()
    }

    /// Takes the evidence of one written step (its classified beams at the step's pose, with
    /// the pose's spread `(σ_xy m, σ_yaw rad)`), then decides the cells it touched in
    /// `current` (`M_i`), appending every state change to `changes`.
    pub fn step(
        &mut self,
        beams: &[Beam],
        lidars: &[LidarFrame],
        sigma: (f64, f64),
        (base, current): (&OccupancyGrid, &mut OccupancyGrid),
        (p, established): (&EvidenceParams, &dyn Fn(u32) -> bool),
        changes: &mut Vec<CellChange>,
    ) {
        self.observe(beams, lidars, sigma, current, p);
        self.decide((base, established), current, p, changes);
    }

    fn observe(
        &mut self,
        beams: &[Beam],
        lidars: &[LidarFrame],
        (sigma_xy, sigma_yaw): (f64, f64),
        map: &OccupancyGrid,
        p: &EvidenceParams,
    ) {
        self.observations.clear();
        let g = *map.geometry();
        let half = 0.5 * g.resolution_m();
        let sigma_xy = sigma_xy.max(p.min_xy_sigma_m);
        let sigma_yaw = sigma_yaw.max(p.min_yaw_sigma_deg.to_radians());
        let sin_min = p.min_incidence_deg.to_radians().sin();
        for (k, b) in beams.iter().enumerate() {
            if b.class == BeamClass::Invalid {
                continue;
            }
            let sigma = (sigma_xy * sigma_xy + (b.range_m * sigma_yaw).powi(2)).sqrt();
            let weight = 1.0 - (sigma / p.max_sigma_m).powi(2);
            if weight <= 0.0 {
                continue;
            }
            let Some(surface) = Surface::fit(beams, k, p.planarity_m) else { continue };
            let origin = lidars[b.lidar as usize].origin;
            let (dx, dy) = (b.angle_rad.cos(), b.angle_rad.sin());
            // The normal, towards the lidar; the beam's incidence on the surface.
            let n = if surface.normal.0 * dx + surface.normal.1 * dy > 0.0 {
                (-surface.normal.0, -surface.normal.1)
            } else {
                surface.normal
            };
            let cos_in = -(n.0 * dx + n.1 * dy);
            if cos_in < sin_min {
                continue;
            }
            // Where the beam meets the fitted surface: the end point with the range noise of
            // one beam averaged over its neighbours'.
            let along = (n.0 * (surface.point.x - origin.x) + n.1 * (surface.point.y - origin.y)) / (-cos_in);
            if !(along.is_finite() && (along - b.range_m).abs() <= p.planarity_m.max(half)) {
                continue;
            }
            let meet = Point2::new(origin.x + dx * along, origin.y + dy * along);
            let Some(end) = g.world_to_cell(meet).and_then(|c| g.index(c)) else { continue };
            let weight = weight as f32;
            self.observations.push(Observation { index: end as u32, weight, hit: true });
            let t0 = ((along - p.band_m) / along).max(0.0);
            let from = Point2::new(origin.x + dx * along * t0, origin.y + dy * along * t0);
            // A crossed cell is free only if the surface does not pass through it: its centre
            // lies in front of the surface by more than its half-extent along the normal.
            let extent = half * (n.0.abs() + n.1.abs()) + p.surface_margin_m;
            let observations = &mut self.observations;
            let _ = traverse_indexed(&g, from, meet, |c, i| {
                let centre = g.cell_center(c);
                let s = n.0 * (centre.x - meet.x) + n.1 * (centre.y - meet.y);
                if i != end && s > extent {
                    observations.push(Observation { index: i as u32, weight, hit: false });
                }
                ControlFlow::<()>::Continue(())
            });
        }
    }

    fn decide(
        &mut self,
        (base, established): (&OccupancyGrid, &dyn Fn(u32) -> bool),
        current: &mut OccupancyGrid,
        p: &EvidenceParams,
        changes: &mut Vec<CellChange>,
    ) {
        self.observations.sort_unstable_by_key(|o| o.index);
        let g = *current.geometry();
        let cap = p.max_weight as f32;
        let mut i = 0;
        while i < self.observations.len() {
            let index = self.observations[i].index;
            let (mut hits, mut passes, mut weight) = (0u32, 0u32, 0f32);
            while i < self.observations.len() && self.observations[i].index == index {
                let o = self.observations[i];
                if o.hit {
                    hits += 1;
                } else {
                    passes += 1;
                }
                weight = weight.max(o.weight);
                i += 1;
            }
            let hit = hits >= passes;
            let idx = index as usize;
            let state = current.cells()[idx];
            let record = match self.records.get_mut(&index) {
                Some(r) => r,
                None if hit != (state == CellState::Occupied) => self.records.entry(index).or_default(),
                None => continue,
            };
            if hit {
                record.hit += weight;
            } else {
                record.pass += weight;
            }
            let total = record.weight();
            if total > cap {
                let s = cap / total;
                record.hit *= s;
                record.pass *= s;
            }
            let (share, total) = (f64::from(record.share()), f64::from(record.weight()));
            let cell = g.coord(idx);
            let mut to = state;
            if total >= p.min_weight {
                if state != CellState::Occupied && share >= p.occupied_share {
                    let beside_structure = cell.neighbours8().into_iter().any(|n| {
                        g.index(n).is_some_and(|j| {
                            base.cells()[j] == CellState::Occupied && (p.grow_established || !established(j as u32))
                        })
                    });
                    if beside_structure {
                        to = CellState::Occupied;
                    }
                } else if state != CellState::Free && share <= p.free_share {
                    to = CellState::Free;
                }
            }
            if to != state {
                current.cells_mut()[idx] = to;
                changes.push(CellChange { cell, from: state, to });
            }
            let settled = match to {
                CellState::Occupied => share >= 1.0 - p.drop_margin,
                CellState::Free => share <= p.drop_margin,
                CellState::Unknown => false,
            };
            if settled && total >= p.min_weight {
                self.records.remove(&index);
            }
        }
    }
}

/// The surface a beam ended on, fitted to its end point and its neighbours' in the same scan.
#[derive(Clone, Copy, Debug)]
struct Surface {
    /// A point of the fitted line (the centroid of the end points).
    point: Point2,
    /// Its unit normal (either side).
    normal: (f64, f64),
}

impl Surface {
    /// The line through the end points of beams `k − 2 … k + 2` of the same scan (total least
    /// squares), if all five are valid and lie within `planarity_m` (RMS) of it: one surface, not
    /// a corner, a leg or an edge.
    fn fit(beams: &[Beam], k: usize, planarity_m: f64) -> Option<Surface> {
        let lo = k.checked_sub(2)?;
        let window = beams.get(lo..=k + 2)?;
        let lidar = beams[k].lidar;
        if window.iter().any(|b| b.lidar != lidar || b.class == BeamClass::Invalid) {
            return None;
        }
        let n = window.len() as f64;
        let (mx, my) = window.iter().fold((0.0, 0.0), |(x, y), b| (x + b.hit.x / n, y + b.hit.y / n));
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for b in window {
            let (u, v) = (b.hit.x - mx, b.hit.y - my);
            sxx += u * u;
            sxy += u * v;
            syy += v * v;
        }
        // Smallest eigenvalue of the scatter matrix and its eigenvector (the normal).
        let tr = sxx + syy;
        let det = sxx * syy - sxy * sxy;
        let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
        let small = 0.5 * tr - disc;
        if small.is_nan() || small / n > planarity_m * planarity_m {
            return None;
        }
        let (nx, ny) = if sxy.abs() > 1e-12 {
            (sxy, small - sxx)
        } else if sxx <= syy {
            (1.0, 0.0)
        } else {
            (0.0, 1.0)
        };
        let len = nx.hypot(ny);
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        Some(Surface { point: Point2::new(mx, my), normal: (nx / len, ny / len) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_field() {
        assert!(EvidenceParams::default().validate().is_ok());
        let p = EvidenceParams { free_share: 0.6, ..EvidenceParams::default() };
        assert_eq!(p.validate().unwrap_err().name, "evidence.free_share");
        let p = EvidenceParams { max_weight: 1.0, ..EvidenceParams::default() };
        assert_eq!(p.validate().unwrap_err().name, "evidence.max_weight");
        let p = EvidenceParams { band_m: f64::NAN, ..EvidenceParams::default() };
        assert_eq!(p.validate().unwrap_err().name, "evidence.band_m");
    }

    #[test]
    fn share_and_weight() {
        let e = CellEvidence { hit: 1.0, pass: 3.0 };
        assert_eq!((e.weight(), e.share()), (4.0, 0.25));
        assert_eq!(CellEvidence::default().share(), 0.0);
    }
}
