//! The saved worlds of a validation (`validate --save-maps`): per seed and saved world i,
//! `seed-S/maps/M_iii.{yaml,pgm}` (M_i), `G_iii.{yaml,pgm}` (G_i) and `E_iii.png`, the errors of
//! M_i against G_i rendered with [`mapkeeper_grid::render::render_errors`] (red: wrongly free,
//! orange: wrongly occupied, blue: missing); W_1 (M_1 against G_1) always. `report.md` lists them
//! with their scores and links ([`saved_worlds_md`]); `report.html` steps through the images.

use crate::experiments::validation::{Scores, SeedRecord, SeedRun, ValidationRecord};
use crate::results::ResultsError;
use crate::results::html::{Frame, WorldStepper};
use mapkeeper_grid::map_io::save_map;
use mapkeeper_grid::render::render_errors;
use mapkeeper_grid::{OccupancyGrid, StagedDir};
use mapkeeper_sensor::tum::format_tum;
use std::fmt::Write as _;

/// A saved world's file inside the validation folder: `kind` is `M` (the map), `G` (the
/// ground truth, both `.yaml` with a `.pgm` beside it) or `E` (the error image, `.png`).
pub fn map_file(seed: u64, kind: char, world: usize) -> String {
    let ext = if kind == 'E' { "png" } else { "yaml" };
    format!("seed-{seed}/maps/{kind}_{world:03}.{ext}")
}

/// The worlds whose files a seed of this record has: W_1 and the saved worlds the seed ran.
pub fn saved_worlds_of(record: &ValidationRecord, seed: &SeedRecord) -> Vec<usize> {
    let mut worlds = vec![1];
    worlds.extend(record.params.saved_worlds.iter().copied().filter(|&w| seed.rows.iter().any(|r| r.world == w)));
    worlds.sort_unstable();
    worlds.dedup();
    worlds
}

/// The scores of M_i against G_i for world `world` of `seed` (M_1/G_1 for W_1).
pub fn scores_of(seed: &SeedRecord, world: usize) -> Option<Scores> {
    if world == 1 {
        return Some(seed.initial_scores);
    }
    seed.rows.iter().find(|r| r.world == world).map(|r| r.updated_map)
}

fn save_world(
    dir: &StagedDir,
    seed: u64,
    world: usize,
    map: &OccupancyGrid,
    truth: &OccupancyGrid,
) -> Result<(), ResultsError> {
    save_map(map, &dir.file(&map_file(seed, 'M', world))?)?;
    save_map(truth, &dir.file(&map_file(seed, 'G', world))?)?;
    let what = map_file(seed, 'E', world);
    let image = render_errors(map, truth)
        .map_err(|e| ResultsError::Serialise { what: what.clone(), message: e.to_string() })?;
    let path = dir.file(&what)?;
    image.write_png(&path).map_err(|e| ResultsError::Serialise { what, message: e.to_string() })
}

/// Writes each seed's saved worlds (maps, ground truths, error images) and trajectories.
pub fn write_saved_worlds(dir: &StagedDir, runs: &[SeedRun]) -> Result<(), ResultsError> {
    for r in runs {
        save_world(dir, r.seed, 1, &r.initial_map, &r.initial_ground_truth)?;
        for w in &r.saved {
            save_world(dir, r.seed, w.world, &w.map, &w.ground_truth)?;
            if let Some(t) = &w.trajectories {
                for (name, poses) in [("true", &t.truth), ("chain", &t.chain), ("baseline", &t.baseline)] {
                    dir.write(
                        &format!("seed-{}/trajectories/W_{:03}_{name}.tum", r.seed, w.world),
                        format_tum(poses).as_bytes(),
                    )?;
                }
            }
        }
    }
    Ok(())
}

/// The `report.md` section listing the saved worlds: per seed and world, M_i/G_i's scores and
/// links to the error image, M_i and G_i.
pub fn saved_worlds_md(record: &ValidationRecord) -> String {
    if record.seeds.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Saved worlds\n\nM_i against G_i for the worlds kept (`validate --save-maps all|LIST`; W_1 is M_1 against G_1). \
         In the error images red is wrongly free (a wall the map lost), orange wrongly occupied (a wall the map keeps \
         or invents), blue missing (known in G_i, unknown in M_i); black, white and grey are right.\n\n\
         | seed | world | CC | MS | OPDF | files |\n|---|---|---|---|---|---|\n",
    );
    for seed in &record.seeds {
        for w in saved_worlds_of(record, seed) {
            let Some(sc) = scores_of(seed, w) else { continue };
            let _ = writeln!(
                s,
                "| {} | W_{w} | {:.2} | {:.2} | {:.2} | [errors]({}) · [M_{w}]({}) · [G_{w}]({}) |",
                seed.seed,
                sc.cc,
                sc.ms,
                sc.opdf,
                map_file(seed.seed, 'E', w),
                map_file(seed.seed, 'M', w),
                map_file(seed.seed, 'G', w)
            );
        }
    }
    s
}

/// The world steppers of a validation record: one per seed, a frame per saved world.
pub fn world_steppers(record: &ValidationRecord) -> Vec<WorldStepper> {
    record
        .seeds
        .iter()
        .map(|seed| WorldStepper {
            id: format!("worlds-seed-{}", seed.seed),
            title: format!("Seed {}", seed.seed),
            frames: saved_worlds_of(record, seed)
                .into_iter()
                .filter_map(|w| {
                    let sc = scores_of(seed, w)?;
                    let what = if w == 1 { "M_1 against G_1" } else { "M_i against G_i" };
                    Some(Frame {
                        world: w,
                        caption: format!("W_{w} ({what}): CC {:.2}, MS {:.2}, OPDF {:.2}", sc.cc, sc.ms, sc.opdf),
                        image: map_file(seed.seed, 'E', w),
                    })
                })
                .collect(),
        })
        .filter(|s| !s.frames.is_empty())
        .collect()
}
