//! Checkpoints of a sweep's jobs, so that a killed `validate` re-run with `--resume` skips the
//! (preset, seed) jobs it had finished.
//!
//! Each finished job is written at once, atomically, to `<folder>/<preset>-s<seed>.json` (with
//! the job's MCAP bags copied beside it): the whole [`SeedRun`] (scores, rows, edits, maps,
//! trajectories, timings) and a fingerprint of what computed it, the preset's parameters as
//! JSON and a hash of the world W_1. A checkpoint is used only when its fingerprint equals the
//! current job's; otherwise the resume is refused with the file named (it belongs to another
//! run). Floats are written so they read back bit for bit (`serde_json`'s `float_roundtrip`),
//! so a resumed sweep's outputs equal an uninterrupted one's.

use crate::experiments::ExperimentError;
use crate::experiments::validation::{SeedRun, ValidationParams, ValidationRun, mcap_name};
use mapkeeper_grid::{hidden_sibling, write_atomic};
use mapkeeper_sim::World;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Version of the checkpoint files; other versions are refused. 2: world rows carry structure
/// retention and change classes; a version-1 checkpoint would resume without them, and the
/// resumed outputs would differ from an uninterrupted run's. 3: the fingerprint's parameters no
/// longer hold `runner.parallel_baseline` (a [`mapkeeper_closed_loop::RunOptions`]); a version-2 checkpoint
/// would be refused as another run's instead of as an older one. 4: the updater's removal
/// gates are the `removal` section of the fingerprint's parameters (they were flat fields);
/// a version-3 checkpoint would likewise be refused as another run's.
const FORMAT: u32 = 4;

/// What computed a job: compared field for field before a checkpoint is used.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Fingerprint {
    /// The preset's parameters (as in summary.json), without how the run is executed.
    params: serde_json::Value,
    /// FNV-1a 64 of W_1's TOML, hexadecimal; "default" for the embedded warehouse.
    world: String,
    /// The run seed.
    seed: u64,
}

/// One checkpoint file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JobFile {
    format: u32,
    fingerprint: Fingerprint,
    /// Names of the job's MCAP bags kept beside the checkpoint.
    mcap: Vec<String>,
    run: SeedRun,
}

/// What a checkpoint must match: the serialised parameters (how the run is executed,
/// [`mapkeeper_closed_loop::RunOptions`], is not among them), the world W_1 the run was given
/// (`None`: the embedded default warehouse), the seed.
fn fingerprint(params: &ValidationParams, w1: Option<&World>, seed: u64) -> Result<Fingerprint, ExperimentError> {
    let world = match w1 {
        Some(w) => format!("{:016x}", mapkeeper_sim::seeds::fnv1a64(w.to_toml_string()?.as_bytes())),
        None => "default".to_string(),
    };
    let params = serde_json::to_value(params).map_err(|e| ExperimentError::Invalid(format!("parameters: {e}")))?;
    Ok(Fingerprint { params, world, seed })
}

/// The job's MCAP bag names (as the validation writes them).
fn mcap_names(params: &ValidationParams, seed: u64) -> Vec<String> {
    params.mcap_worlds.iter().map(|&i| mcap_name(&params.preset, seed, i)).collect()
}

/// The checkpoint folder of one run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Checkpoints {
    dir: PathBuf,
}

impl Checkpoints {
    /// The checkpoints of a run whose output folder is `target`: `.NAME.jobs` beside it (not in
    /// its staging folder, which an interrupted run's successor removes).
    pub fn beside(target: &Path) -> Checkpoints {
        Checkpoints { dir: hidden_sibling(target, "jobs") }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The checkpoint file of a job.
    pub fn file(&self, preset: &str, seed: u64) -> PathBuf {
        self.dir.join(format!("{preset}-s{seed}.json"))
    }

    fn err(path: &Path, problem: impl std::fmt::Display) -> ExperimentError {
        ExperimentError::Checkpoint { path: path.to_path_buf(), problem: problem.to_string() }
    }

    /// Writes a finished job of `params` given `given` (its W_1 and MCAP folder), copying its
    /// MCAP bags from that folder.
    pub fn save(
        &self,
        params: &ValidationParams,
        given: &ValidationRun<'_>,
        run: &SeedRun,
    ) -> Result<(), ExperimentError> {
        std::fs::create_dir_all(&self.dir).map_err(|e| Self::err(&self.dir, e))?;
        let mcap = mcap_names(params, run.seed);
        if let Some(src) = given.mcap_dir {
            for name in &mcap {
                let (from, to) = (src.join(name), self.dir.join(name));
                std::fs::copy(&from, &to).map_err(|e| Self::err(&to, format!("copying {}: {e}", from.display())))?;
            }
        }
        let file =
            JobFile { format: FORMAT, fingerprint: fingerprint(params, given.w1, run.seed)?, mcap, run: run.clone() };
        let path = self.file(&params.preset, run.seed);
        let bytes = serde_json::to_vec(&file).map_err(|e| Self::err(&path, e))?;
        write_atomic(&path, &bytes).map_err(|e| Self::err(&path, e))
    }

    /// The finished run of a job, if its checkpoint is there; its MCAP bags are copied back to
    /// `given.mcap_dir`. A checkpoint that cannot be read, or that another run wrote (its
    /// parameters, world or seed differ), is an error naming the file.
    pub fn load(
        &self,
        params: &ValidationParams,
        given: &ValidationRun<'_>,
        seed: u64,
    ) -> Result<Option<SeedRun>, ExperimentError> {
        let path = self.file(&params.preset, seed);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(Self::err(&path, e)),
        };
        let file: JobFile = serde_json::from_slice(&bytes)
            .map_err(|e| Self::err(&path, format!("unreadable ({e}); remove it to run the job again")))?;
        if file.format != FORMAT {
            return Err(Self::err(&path, format!("format {} is not {FORMAT}; remove it", file.format)));
        }
        let want = fingerprint(params, given.w1, seed)?;
        if file.fingerprint != want || file.run.seed != seed {
            let what = if file.fingerprint.world != want.world {
                "another world"
            } else if file.fingerprint.seed != seed || file.run.seed != seed {
                "another seed"
            } else {
                "other parameters"
            };
            return Err(Self::err(
                &path,
                format!(
                    "was written by a run with {what}; resume with the same flags, or remove {}",
                    self.dir.display()
                ),
            ));
        }
        if file.mcap != mcap_names(params, seed) {
            return Err(Self::err(&path, "its MCAP bags are not the ones this run asks for"));
        }
        if let Some(dst) = given.mcap_dir {
            for name in &file.mcap {
                let (from, to) = (self.dir.join(name), dst.join(name));
                std::fs::copy(&from, &to).map_err(|e| Self::err(&from, format!("copying to {}: {e}", to.display())))?;
            }
        }
        Ok(Some(file.run))
    }

    /// Removes the folder (the run is complete).
    pub fn remove(&self) -> Result<(), ExperimentError> {
        match std::fs::remove_dir_all(&self.dir) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(Self::err(&self.dir, e)),
        }
    }

    /// How many checkpoint files the folder holds (0 if there is none).
    pub fn count(&self) -> usize {
        std::fs::read_dir(&self.dir)
            .map(|d| d.flatten().filter(|e| e.path().extension().is_some_and(|x| x == "json")).count())
            .unwrap_or(0)
    }
}
