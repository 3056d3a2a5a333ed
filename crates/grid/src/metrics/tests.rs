//! Unit tests of `metrics`.

use super::*;
use crate::grid::CellCoord;
use crate::pose::{Point2, Pose2};
use proptest::prelude::*;

const F: CellState = CellState::Free;
const O: CellState = CellState::Occupied;
const U: CellState = CellState::Unknown;

/// A grid from rows written top row first (as drawn), at 1 m per cell (also the `erosion`
/// module's tests).
pub(super) fn grid(rows_top_first: &[&[CellState]]) -> OccupancyGrid {
    grid_res(rows_top_first, 1.0)
}

fn grid_res(rows_top_first: &[&[CellState]], res: f64) -> OccupancyGrid {
    let h = rows_top_first.len();
    let w = rows_top_first[0].len();
    let g = GridGeometry::new(w, h, res, Pose2::IDENTITY).unwrap();
    let cells = rows_top_first.iter().rev().flat_map(|r| r.iter().copied()).collect();
    OccupancyGrid::from_cells(g, cells).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// Window giving a chosen r at 1 m per cell: w = h = r / √2.
fn params_with_r(r: f64) -> MetricParams {
    let side = r / 2f64.sqrt();
    MetricParams { opdf_window_m: (side, side), ..MetricParams::default() }
}

#[test]
fn cc_hand_computed_3x3() {
    // a: O at (0,0) and (1,1); b: O at (0,0) only; everything else free.
    // Values a = [1,1,0,...] (2 ones of 9), b = [1,0,...] (1 one of 9), overlap 1 cell.
    // ⟨A⟩ = 2/9, ⟨B⟩ = 1/9, ⟨AB⟩ = 1/9.
    // cov = 1/9 − 2/81 = 7/81. σA² = 2/9 − 4/81 = 14/81, σB² = 1/9 − 1/81 = 8/81.
    // CC = 100 · 7 / √(14·8) = 100 · 7/√112 ≈ 66.1438.
    let a = grid(&[&[F, F, F], &[F, O, F], &[O, F, F]]);
    let b = grid(&[&[F, F, F], &[F, F, F], &[O, F, F]]);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    assert!(close(m.cc, 700.0 / 112f64.sqrt()), "{}", m.cc);
    assert!(!m.cc_degenerate);
}

#[test]
fn cc_with_unknown_value_4x2() {
    // 4 × 2, u = 0.5. a values: [1, 0, 0.5, 0, 0, 0, 0, 1]; b values: [1, 0, 0, 0, 0, 0, 1, 1].
    // Σa = 2.5, ⟨A⟩ = 0.3125; Σb = 3, ⟨B⟩ = 0.375; Σab = 1 + 1 = 2, ⟨AB⟩ = 0.25.
    // cov = 0.25 − 0.3125·0.375 = 0.1328125.
    // Σa² = 2.25 → σA² = 0.28125 − 0.09765625 = 0.18359375.
    // Σb² = 3 → σB² = 0.375 − 0.140625 = 0.234375.
    // CC = 100 · 0.1328125 / √(0.18359375 · 0.234375).
    let a = grid(&[&[F, F, F, O], &[O, F, U, F]]);
    let b = grid(&[&[F, F, O, O], &[O, F, F, F]]);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    let want = 100.0 * 0.1328125 / (0.18359375f64 * 0.234375).sqrt();
    assert!(close(m.cc, want), "{} vs {want}", m.cc);
    // Symmetric.
    let n = map_metrics(&b, &a, &MetricParams::default()).unwrap();
    assert!(close(m.cc, n.cc));
}

#[test]
fn cc_anticorrelated_is_minus_100() {
    let a = grid(&[&[O, F], &[F, O]]);
    let b = grid(&[&[F, O], &[O, F]]);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    assert!(close(m.cc, -100.0), "{}", m.cc);
}

#[test]
fn cc_zero_variance_rule() {
    let free = grid(&[&[F, F], &[F, F]]);
    let unknown = grid(&[&[U, U], &[U, U]]);
    let some = grid(&[&[O, F], &[F, F]]);
    let p = MetricParams::default();
    // Identical constant maps: 100.
    let m = map_metrics(&free, &free, &p).unwrap();
    assert_eq!(m.cc, 100.0);
    assert!(m.cc_degenerate);
    // Different constants, or one constant: 0.
    assert_eq!(map_metrics(&free, &unknown, &p).unwrap().cc, 0.0);
    assert_eq!(map_metrics(&free, &some, &p).unwrap().cc, 0.0);
    assert_eq!(map_metrics(&some, &free, &p).unwrap().cc, 0.0);
    // With unknown_value = 0, unknown and free cells have equal values: "identical".
    let p0 = MetricParams { unknown_value: 0.0, ..p };
    assert_eq!(map_metrics(&free, &unknown, &p0).unwrap().cc, 100.0);
}

#[test]
fn ms_hand_computed() {
    // 3 × 3, u = 0.5.
    // a:  O F U      b:  O O F
    //     F F F          F U F
    //     U F O          O F F
    // Cells occupied in a or b: (top) a=O,b=O → 0; a=F,b=O → 1;
    // (bottom) a=U,b=O → 0.25; a=O,b=F → 1. ν′ = 4, Σ = 2.25.
    // MS = 100 · (1 − 2.25/4) = 43.75.
    let a = grid(&[&[O, F, U], &[F, F, F], &[U, F, O]]);
    let b = grid(&[&[O, O, F], &[F, U, F], &[O, F, F]]);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    assert_eq!(m.union_occupied, 4);
    assert!(close(m.ms, 43.75), "{}", m.ms);
    assert!(close(map_metrics(&b, &a, &MetricParams::default()).unwrap().ms, 43.75));
    // With u = 0.2 the (U, O) cell costs 0.64: MS = 100 · (1 − 2.64/4) = 34.
    let m = map_metrics(&a, &b, &MetricParams { unknown_value: 0.2, ..MetricParams::default() }).unwrap();
    assert!(close(m.ms, 34.0), "{}", m.ms);
}

#[test]
fn ms_no_occupied_cell_is_100() {
    let a = grid(&[&[F, U], &[F, F]]);
    let b = grid(&[&[U, U], &[F, U]]);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    assert_eq!(m.union_occupied, 0);
    assert_eq!(m.ms, 100.0);
}

#[test]
fn manhattan_transform_matches_brute_force_small() {
    // 4 × 3 with occupied cells at (0,0) and (3,2).
    let a = grid(&[&[F, F, F, O], &[F, F, F, F], &[O, F, F, F]]);
    let mut d = vec![0u32; 12];
    manhattan_to_occupied(&a, None, &mut d);
    // Row 0 (bottom): (0,0)=0, (1,0)=1, (2,0)=2, (3,0)=min(3 to (0,0), 2 to (3,2))=2.
    assert_eq!(&d[0..4], &[0, 1, 2, 2]);
    // Row 1: (0,1)=1, (1,1)=min(2, 3)=2, (2,1)=min(3, 1+1)=2, (3,1)=1.
    assert_eq!(&d[4..8], &[1, 2, 2, 1]);
    // Row 2 (top): (0,2)=min(2, 3)=2, (1,2)=min(3, 2)=2, (2,2)=1, (3,2)=0.
    assert_eq!(&d[8..12], &[2, 2, 1, 0]);
    // No occupied cell: FAR everywhere.
    let empty = grid(&[&[F, U], &[F, F]]);
    let mut d = vec![0u32; 4];
    manhattan_to_occupied(&empty, None, &mut d);
    assert!(d.iter().all(|&x| x == FAR));
}

#[test]
fn opdf_hand_computed() {
    // 4 × 2 at 1 m per cell, r = 2 (window √2 × √2 m).
    // a:  O F F F     b:  F F F F
    //     F F F O         F O F F
    // a's occupied cells: (0,1) top-left, (3,0) bottom-right; b's: (1,0).
    // a→b: (0,1)→(1,0): 1 + 1 = 2 → min(2, 2) = 2; (3,0)→(1,0): 2 → 2. Σ = 4,
    //   OPDF_as(a, b) = 100 · (1 − 4 / (2 · 2)) = 0.
    // b→a: (1,0)→ nearest of {(0,1): 2, (3,0): 2} = 2 → min(2, 2) = 2: OPDF_as(b, a) = 0.
    let a = grid(&[&[O, F, F, F], &[F, F, F, O]]);
    let b = grid(&[&[F, F, F, F], &[F, O, F, F]]);
    let m = map_metrics(&a, &b, &params_with_r(2.0)).unwrap();
    assert!(close(m.opdf_radius_cells, 2.0));
    assert!(close(m.opdf_ab, 0.0) && close(m.opdf_ba, 0.0), "{m:?}");
    // With r = 4: a→b Σ = 2 + 2 = 4 → 100 · (1 − 4/8) = 50; b→a: 2 → 100 · (1 − 2/4) = 50.
    let m = map_metrics(&a, &b, &params_with_r(4.0)).unwrap();
    assert!(close(m.opdf_ab, 50.0) && close(m.opdf_ba, 50.0), "{m:?}");
    // Move b's cell to (2,0): a→b: (0,1) → 2 + 1 = 3, (3,0) → 1; Σ = 4 → 50.
    //   b→a: (2,0) → (3,0) is 1 → 100 · (1 − 1/4) = 75. OPDF = 62.5.
    let b2 = grid(&[&[F, F, F, F], &[F, F, O, F]]);
    let m = map_metrics(&a, &b2, &params_with_r(4.0)).unwrap();
    assert!(close(m.opdf_ab, 50.0) && close(m.opdf_ba, 75.0) && close(m.opdf, 62.5), "{m:?}");
    let n = map_metrics(&b2, &a, &params_with_r(4.0)).unwrap();
    assert!(close(n.opdf_ab, 75.0) && close(n.opdf_ba, 50.0) && close(n.opdf, m.opdf));
}

#[test]
fn opdf_default_window_at_5cm() {
    // Default 1 m × 1 m at 0.05 m: 20 × 20 cells, r = √800.
    // a: one occupied cell at (0,0); b: one at (3,4): L1 = 7.
    // OPDF_as = 100 · (1 − 7/√800) both ways.
    let g = GridGeometry::new(10, 10, 0.05, Pose2::IDENTITY).unwrap();
    let mut a = OccupancyGrid::filled(g, F);
    let mut b = OccupancyGrid::filled(g, F);
    a.set(CellCoord::new(0, 0), O);
    b.set(CellCoord::new(3, 4), O);
    let m = map_metrics(&a, &b, &MetricParams::default()).unwrap();
    assert!(close(m.opdf_radius_cells, 800f64.sqrt()));
    let want = 100.0 * (1.0 - 7.0 / 800f64.sqrt());
    assert!(close(m.opdf_ab, want) && close(m.opdf_ba, want) && close(m.opdf, want), "{m:?}");
}

#[test]
fn opdf_empty_cases() {
    let none = grid(&[&[F, U], &[F, F]]);
    let some = grid(&[&[O, U], &[F, F]]);
    let p = MetricParams::default();
    // Both empty: 100 each way.
    let m = map_metrics(&none, &none, &p).unwrap();
    assert_eq!((m.opdf_ab, m.opdf_ba, m.opdf), (100.0, 100.0, 100.0));
    // One empty: the empty side scores 0 by the rule, the other side 0 because every
    // distance is capped at r.
    let m = map_metrics(&none, &some, &p).unwrap();
    assert_eq!((m.opdf_ab, m.opdf_ba, m.opdf), (0.0, 0.0, 0.0));
    let m = map_metrics(&some, &none, &p).unwrap();
    assert_eq!((m.opdf_ab, m.opdf_ba, m.opdf), (0.0, 0.0, 0.0));
}

#[test]
fn identical_maps_score_100() {
    let a = grid(&[&[O, F, U, O], &[F, O, F, U], &[U, U, F, O]]);
    let m = map_metrics(&a, &a, &MetricParams::default()).unwrap();
    assert!(close(m.cc, 100.0) && close(m.ms, 100.0) && close(m.opdf, 100.0), "{m:?}");
    assert_eq!((m.cells, m.occupied_a, m.occupied_b, m.union_occupied), (12, 4, 4, 4));
}

#[test]
fn geometry_mismatch_and_bad_params() {
    let a = grid(&[&[O, F], &[F, F]]);
    let b = grid_res(&[&[O, F], &[F, F]], 0.5);
    assert_eq!(map_metrics(&a, &b, &MetricParams::default()), Err(MetricsError::Grid(GridError::GeometryMismatch)));
    for p in [
        MetricParams { unknown_value: f64::NAN, ..MetricParams::default() },
        MetricParams { unknown_value: 1.5, ..MetricParams::default() },
        MetricParams { opdf_window_m: (0.0, 1.0), ..MetricParams::default() },
        MetricParams { opdf_window_m: (1.0, f64::INFINITY), ..MetricParams::default() },
    ] {
        assert!(matches!(map_metrics(&a, &a, &p), Err(MetricsError::InvalidParam { .. })), "{p:?}");
    }
    assert!(toml::from_str::<MetricParams>("bogus = 1").is_err());
    let e = MetricParams { unknown_value: 1.5, ..MetricParams::default() }.validate().unwrap_err();
    assert!(
        matches!(&e, MetricsError::InvalidParam(p) if p.name == "unknown_value" && p.value == "1.5"
            && p.requirement == "must be a number in [0, 1]"),
        "{e:?}"
    );
    assert_eq!(e.to_string(), "metric parameter unknown_value = 1.5 is invalid: must be a number in [0, 1]");
}

#[test]
fn resample_nearest_centre_and_outside_unknown() {
    let a = grid(&[&[O, F], &[F, U]]);
    // Same geometry: unchanged.
    assert_eq!(resample_onto(&a, a.geometry()), a);
    // Shifted by one cell to the right: column 0 takes a's column 1, column 1 is outside.
    let shifted = GridGeometry::new(2, 2, 1.0, Pose2::new(1.0, 0.0, 0.0)).unwrap();
    let r = resample_onto(&a, &shifted);
    assert_eq!(r.get(CellCoord::new(0, 1)), Some(F));
    assert_eq!(r.get(CellCoord::new(0, 0)), Some(U));
    assert_eq!(r.get(CellCoord::new(1, 0)), Some(U));
    assert_eq!(r.get(CellCoord::new(1, 1)), Some(U));
    // Finer target: each fine cell takes the coarse cell containing its centre.
    let fine = GridGeometry::new(4, 4, 0.5, Pose2::IDENTITY).unwrap();
    let r = resample_onto(&a, &fine);
    assert_eq!(r.count(O), 4);
    assert_eq!(r.get_world(Point2::new(0.25, 1.75)), Some(O));
}

fn arb_grid_pair() -> impl Strategy<Value = (OccupancyGrid, OccupancyGrid)> {
    (1usize..12, 1usize..12).prop_flat_map(|(w, h)| {
        let states = prop::sample::select(vec![F, O, U]);
        (prop::collection::vec(states.clone(), w * h), prop::collection::vec(states, w * h)).prop_map(
            move |(ca, cb)| {
                let g = GridGeometry::new(w, h, 0.05, Pose2::IDENTITY).unwrap();
                (OccupancyGrid::from_cells(g, ca).unwrap(), OccupancyGrid::from_cells(g, cb).unwrap())
            },
        )
    })
}

/// Brute-force OPDF_as with a per-cell search.
fn brute_opdf_as(m: &OccupancyGrid, other: &OccupancyGrid, r: f64) -> f64 {
    let g = m.geometry();
    let occ: Vec<CellCoord> = (0..g.len()).filter(|&i| other.cells()[i] == O).map(|i| g.coord(i)).collect();
    let mine: Vec<CellCoord> = (0..g.len()).filter(|&i| m.cells()[i] == O).map(|i| g.coord(i)).collect();
    if mine.is_empty() {
        return if occ.is_empty() { 100.0 } else { 0.0 };
    }
    let sum: f64 = mine
        .iter()
        .map(|c| {
            let best = occ.iter().map(|o| (o.ix - c.ix).abs() + (o.iy - c.iy).abs()).min();
            best.map_or(r, |d| (d as f64).min(r))
        })
        .sum();
    100.0 * (1.0 - sum / (mine.len() as f64 * r))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn finite_in_range_and_symmetric((a, b) in arb_grid_pair(), u in 0.0f64..=1.0, win in 0.01f64..2.0) {
        let p = MetricParams { unknown_value: u, opdf_window_m: (win, win * 0.7) };
        let m = map_metrics(&a, &b, &p).unwrap();
        let n = map_metrics(&b, &a, &p).unwrap();
        for v in [m.cc, m.ms, m.opdf, m.opdf_ab, m.opdf_ba] {
            prop_assert!(v.is_finite());
        }
        prop_assert!((-100.0..=100.0).contains(&m.cc));
        prop_assert!((0.0..=100.0).contains(&m.ms));
        prop_assert!((0.0..=100.0).contains(&m.opdf_ab) && (0.0..=100.0).contains(&m.opdf_ba));
        prop_assert!((m.cc - n.cc).abs() < 1e-9);
        prop_assert!((m.ms - n.ms).abs() < 1e-9);
        prop_assert!((m.opdf - n.opdf).abs() < 1e-9);
        prop_assert!((m.opdf_ab - n.opdf_ba).abs() < 1e-12);
        let r = m.opdf_radius_cells;
        prop_assert!((m.opdf_ab - brute_opdf_as(&a, &b, r)).abs() < 1e-9);
        prop_assert!((m.opdf_ba - brute_opdf_as(&b, &a, r)).abs() < 1e-9);
        let s = map_metrics(&a, &a, &p).unwrap();
        prop_assert!((s.cc - 100.0).abs() < 1e-9 && s.ms == 100.0 && s.opdf == 100.0);
    }

    /// Masked metrics: an all-true mask gives the unmasked figures exactly; otherwise CC and
    /// MS are those of the masked cells alone (laid out as one row: neither depends on the
    /// layout) and OPDF is the brute-force search among masked cells.
    #[test]
    fn masked_metrics_are_the_metrics_of_the_masked_cells(
        (a, b) in arb_grid_pair(),
        bits in prop::collection::vec(any::<bool>(), 144),
        u in 0.0f64..=1.0,
    ) {
        let p = MetricParams { unknown_value: u, ..MetricParams::default() };
        let n = a.cells().len();
        prop_assert_eq!(map_metrics_in(&a, &b, &vec![true; n], &p).unwrap(), map_metrics(&a, &b, &p).unwrap());
        let mask = &bits[..n];
        let m = map_metrics_in(&a, &b, mask, &p).unwrap();
        let picked: Vec<usize> = (0..n).filter(|&i| mask[i]).collect();
        prop_assert_eq!(m.cells, picked.len());
        if !picked.is_empty() {
            let row = GridGeometry::new(picked.len(), 1, 0.05, Pose2::IDENTITY).unwrap();
            let take = |g: &OccupancyGrid| {
                OccupancyGrid::from_cells(row, picked.iter().map(|&i| g.cells()[i]).collect()).unwrap()
            };
            let flat = map_metrics(&take(&a), &take(&b), &p).unwrap();
            prop_assert!((m.cc - flat.cc).abs() < 1e-9 && (m.ms - flat.ms).abs() < 1e-9);
        }
        let hide = |g: &OccupancyGrid| {
            let cells = g.cells().iter().zip(mask).map(|(&s, &k)| if k { s } else { U }).collect();
            OccupancyGrid::from_cells(*g.geometry(), cells).unwrap()
        };
        let r = m.opdf_radius_cells;
        prop_assert!((m.opdf_ab - brute_opdf_as(&hide(&a), &hide(&b), r)).abs() < 1e-9);
        prop_assert!((m.opdf_ba - brute_opdf_as(&hide(&b), &hide(&a), r)).abs() < 1e-9);
        prop_assert!(map_metrics_in(&a, &b, &bits[..n - 1], &p).is_err());
    }
}

#[test]
fn interior_of_an_open_room_is_its_walls_only_and_a_closed_room_holds_its_inside() {
    let closed = grid(&[&[F, F, F, F, F], &[F, O, O, O, F], &[F, O, U, O, F], &[F, O, O, O, F], &[F, F, F, F, F]]);
    let inside = interior_mask(&closed);
    assert_eq!(inside.iter().filter(|&&b| b).count(), 9);
    let open = grid(&[&[F, F, F, F, F], &[F, O, F, O, F], &[F, O, F, O, F], &[F, O, O, O, F], &[F, F, F, F, F]]);
    assert_eq!(interior_mask(&open).iter().filter(|&&b| b).count(), 7);
    let one = grid(&[&[F]]);
    assert_eq!(interior_mask(&one), vec![false]);
    let all = grid(&[&[O, O], &[O, O]]);
    assert_eq!(interior_mask(&all), vec![true; 4]);
}
