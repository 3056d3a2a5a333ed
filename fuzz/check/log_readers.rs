// Each target uses one of the properties below.
#![allow(dead_code)]

// The property of the `ros1_bag`, `ros2_mcap` and `carmen` fuzz targets, shared (by `#[path]`)
// with the test that replays their kept corpus (`crates/logs/tests/fuzz_corpus.rs`): an input,
// written where a user's file would be, is read with the default options and with `--salvage`;
// no read panics, and a refusal is one line that names the file (or bag folder) it read.
//
// The inputs: `ros1_bag` and `carmen` are the file's bytes; a `carmen` input is also read
// gzipped (compressed here: the gzip path on text) and as if it were a `.gz` file (damaged
// gzip). A `ros2_mcap` input is an MCAP file, or a bag folder: `metadata.yaml`, the line
// `---mcap---`, then the MCAP file listed in it as `bag_0.mcap`.

use mapkeeper_logs::{ImportOptions, carmen, ros1, ros2};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The separator of a bag-folder input of `ros2_mcap`.
pub const FOLDER_SEPARATOR: &[u8] = b"\n---mcap---\n";

/// A folder of this process for the files an input is written to.
pub fn scratch_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-fuzz-{what}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

fn options(salvage: bool) -> ImportOptions {
    ImportOptions { salvage, ..ImportOptions::default() }
}

/// Reads `path` with both option sets through `read`, checking the property; returns how many
/// reads succeeded.
fn both<E: std::fmt::Display, T>(path: &Path, read: impl Fn(&Path, &ImportOptions) -> Result<T, E>) -> usize {
    let mut ok = 0;
    for salvage in [false, true] {
        match read(path, &options(salvage)) {
            Ok(_) => ok += 1,
            Err(e) => check_refusal(&e.to_string(), path),
        }
    }
    ok
}

/// A refusal is one line naming the file.
pub fn check_refusal(m: &str, path: &Path) {
    let name = path.display().to_string();
    assert!(m.contains(&name), "error does not name {name}: {m}");
    assert!(!m.contains('\n'), "multi-line error: {m}");
}

/// The `ros1_bag` property; returns the successful reads.
pub fn ros1_bag(data: &[u8], dir: &Path) -> usize {
    let path = dir.join("input.bag");
    std::fs::write(&path, data).expect("write input");
    both(&path, ros1::read)
}

/// The `ros2_mcap` property; returns the successful reads.
pub fn ros2_mcap(data: &[u8], dir: &Path) -> usize {
    let split = data.windows(FOLDER_SEPARATOR.len()).position(|w| w == FOLDER_SEPARATOR);
    match split {
        None => {
            let path = dir.join("input.mcap");
            std::fs::write(&path, data).expect("write input");
            both(&path, ros2::read)
        }
        Some(at) => {
            let bag = dir.join("bag");
            let _ = std::fs::remove_dir_all(&bag);
            std::fs::create_dir_all(&bag).expect("bag folder");
            std::fs::write(bag.join("metadata.yaml"), &data[..at]).expect("write metadata");
            std::fs::write(bag.join("bag_0.mcap"), &data[at + FOLDER_SEPARATOR.len()..]).expect("write mcap");
            both(&bag, ros2::read)
        }
    }
}

/// The `carmen` property (plain, gzipped, and the bytes as a `.gz`); returns the successful reads.
pub fn carmen(data: &[u8], dir: &Path) -> usize {
    let plain = dir.join("input.log");
    std::fs::write(&plain, data).expect("write input");
    let mut ok = both(&plain, carmen::read);
    let gz = dir.join("input.gz.log.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(data).expect("gzip");
    std::fs::write(&gz, enc.finish().expect("gzip")).expect("write input");
    ok += both(&gz, carmen::read);
    let raw = dir.join("input.raw.log.gz");
    std::fs::write(&raw, data).expect("write input");
    ok + both(&raw, carmen::read)
}
