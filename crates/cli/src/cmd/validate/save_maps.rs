//! `--save-maps`: which worlds' maps a validation keeps.

/// `--save-maps`: every world, or the listed ones.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SaveMaps {
    /// W_2 … W_N.
    All,
    /// These worlds (each ≥ 2), sorted, without repeats.
    List(Vec<usize>),
}

impl std::str::FromStr for SaveMaps {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim() == "all" {
            return Ok(SaveMaps::All);
        }
        let mut worlds = Vec::new();
        for part in s.split(',') {
            let w: usize = part
                .trim()
                .parse()
                .map_err(|_| format!("`{part}` is neither `all` nor a world number (e.g. all, or 2,37,50)"))?;
            if w < 2 {
                return Err(format!("world {w}: saved worlds are W_2 or later (W_1 is always saved)"));
            }
            worlds.push(w);
        }
        worlds.sort_unstable();
        worlds.dedup();
        Ok(SaveMaps::List(worlds))
    }
}

impl SaveMaps {
    /// The worlds of a run of `worlds` worlds, or an error naming the flag.
    pub(super) fn resolve(&self, worlds: usize) -> anyhow::Result<Vec<usize>> {
        match self {
            SaveMaps::All => Ok((2..=worlds).collect()),
            SaveMaps::List(list) => match list.iter().find(|&&w| w > worlds) {
                Some(w) => anyhow::bail!("--save-maps: world {w} is beyond --worlds {worlds}"),
                None => Ok(list.clone()),
            },
        }
    }
}
