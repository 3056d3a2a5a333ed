//! The node's saved state in `save_dir`: `map.yaml` + `map.pgm` (map_server format), the
//! cross-world memory that goes with the map (`memory.json`), and the node's counts
//! (`node.json`). Every file is written atomically (beside it, then renamed), the map's YAML
//! after its image and the memory after the map: a node killed at any moment leaves a whole map,
//! and a memory that fits it (a memory is checked against the map when it is read back).

use mapkeeper_grid::OccupancyGrid;
use mapkeeper_updater::StructureMemory;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a save wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Saved {
    /// The map's YAML.
    pub map_path: PathBuf,
}

/// The state read back.
#[derive(Clone, Debug)]
pub struct Resumed {
    /// The map's YAML.
    pub map_path: PathBuf,
    /// The map.
    pub map: OccupancyGrid,
    /// Its memory.
    pub memory: StructureMemory,
}

#[derive(Serialize, Deserialize)]
struct MemoryFile {
    /// The map's cell count, to refuse a memory of another map.
    map_cells: usize,
    memory: StructureMemory,
}

/// Writes the state to `dir` (created if needed); `counts` (the node's) go to `node.json`.
pub fn store(
    dir: &Path,
    map: &OccupancyGrid,
    memory: &StructureMemory,
    counts: &impl Serialize,
) -> Result<Saved, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create: {e}", dir.display()))?;
    let map_path = dir.join("map.yaml");
    mapkeeper_grid::map_io::save_map(map, &map_path).map_err(|e| e.to_string())?;
    let memory_file = MemoryFile { map_cells: map.geometry().len(), memory: memory.clone() };
    let text = serde_json::to_vec(&memory_file).map_err(|e| format!("memory.json: {e}"))?;
    mapkeeper_grid::map_io::write_atomic(&dir.join("memory.json"), &text).map_err(|e| e.to_string())?;
    let text = serde_json::to_vec_pretty(counts).map_err(|e| format!("node.json: {e}"))?;
    mapkeeper_grid::map_io::write_atomic(&dir.join("node.json"), &text).map_err(|e| e.to_string())?;
    Ok(Saved { map_path })
}

/// The state saved in `dir`, if there is a map there (`None` without one); a memory that is
/// missing is empty, one that does not fit the map is refused.
pub fn load(dir: &Path) -> Result<Option<Resumed>, String> {
    let map_path = dir.join("map.yaml");
    if !map_path.is_file() {
        return Ok(None);
    }
    let map = mapkeeper_grid::map_io::load_map(&map_path).map_err(|e| format!("resume: {e}"))?;
    let mem_path = dir.join("memory.json");
    let memory = match std::fs::read(&mem_path) {
        Ok(bytes) => {
            let f: MemoryFile = serde_json::from_slice(&bytes)
                .map_err(|e| format!("{}: not a memory file: {e}", mem_path.display()))?;
            if f.map_cells != map.geometry().len() {
                return Err(format!(
                    "{}: a memory of a {}-cell map beside a {}-cell map: remove it, or the map",
                    mem_path.display(),
                    f.map_cells,
                    map.geometry().len()
                ));
            }
            f.memory
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => StructureMemory::default(),
        Err(e) => return Err(format!("{}: cannot read: {e}", mem_path.display())),
    };
    Ok(Some(Resumed { map_path, map, memory }))
}
