//! The import graph of one crate and the circles in it, as the test reports them.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::PathBuf;

/// The names that tie one file to another: each name, with the first line of the first file
/// that names it.
pub type Ties = BTreeMap<String, usize>;

/// One crate's files and which file names an item of which.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CrateGraph {
    /// The crate's folder, as it was given.
    pub dir: PathBuf,
    /// Every file of its module trees (from `src/lib.rs` and `src/main.rs`), relative to `src/`
    /// with `/` between folders: `results/mod.rs`.
    pub files: BTreeSet<String>,
    /// (from, to) → the names in `from` that `to` defines or re-exports. No file is tied to
    /// itself.
    pub edges: BTreeMap<(String, String), Ties>,
    /// For each file, the files of the modules that enclose its own (`results/merge.rs`:
    /// `results/mod.rs`, `lib.rs`). A tie to one of them is upward (a child naming its
    /// parent's shared types, the crate's error in `lib.rs`): recorded, but not followed when
    /// circles are sought.
    pub enclosing: BTreeMap<String, BTreeSet<String>>,
    /// The `mod x;` declarations whose file was found nowhere (`lib.rs:12: mod x`): a file the
    /// scan could not see.
    pub missing: Vec<String>,
}

/// Files of one crate that import each other round a circle (a strongly connected component
/// of the graph without its upward ties, two files or more), with the ties between them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Circle {
    /// The crate's folder.
    pub dir: PathBuf,
    /// The files, sorted.
    pub files: Vec<String>,
    /// Every tie followed between two of them (none upward): (from, to, the names), sorted.
    pub edges: Vec<(String, String, Ties)>,
}

impl CrateGraph {
    /// The number of (from, to) pairs of files tied by at least one name.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// Whether the tie from `from` to `to` is upward: `to` holds a module enclosing `from`'s.
    pub fn is_upward(&self, from: &str, to: &str) -> bool {
        self.enclosing.get(from).is_some_and(|around| around.contains(to))
    }

    /// The circles of the graph, upward ties left out (Tarjan's strongly connected components
    /// of two files or more), in the order of their files.
    pub fn circles(&self) -> Vec<Circle> {
        let files: Vec<&String> = self.files.iter().collect();
        let index: BTreeMap<&String, usize> = files.iter().enumerate().map(|(k, f)| (*f, k)).collect();
        let arcs: BTreeSet<(usize, usize)> = self
            .edges
            .keys()
            .filter(|(a, b)| !self.is_upward(a, b))
            .filter_map(|(a, b)| Some((*index.get(a)?, *index.get(b)?)))
            .collect();
        let mut circles: Vec<Circle> = super::scc::strongly_connected(files.len(), &arcs)
            .into_iter()
            .filter(|component| component.len() > 1)
            .map(|component| {
                let members: BTreeSet<String> =
                    component.iter().filter_map(|&k| files.get(k).map(|f| (*f).clone())).collect();
                let edges = self
                    .edges
                    .iter()
                    .filter(|((a, b), _)| members.contains(a) && members.contains(b) && !self.is_upward(a, b))
                    .map(|((a, b), ties)| (a.clone(), b.clone(), ties.clone()))
                    .collect();
                Circle { dir: self.dir.clone(), files: members.into_iter().collect(), edges }
            })
            .collect();
        circles.sort_by(|a, b| a.files.cmp(&b.files));
        circles
    }
}

impl fmt::Display for Circle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let src = self.dir.join("src");
        writeln!(f, "{}: {} files import each other round a circle:", src.display(), self.files.len())?;
        for file in &self.files {
            writeln!(f, "    {file}")?;
        }
        writeln!(f, "  tied by (file → file it names: the names, with the line naming each first):")?;
        for (from, to, ties) in &self.edges {
            let names: Vec<String> = ties.iter().map(|(name, line)| format!("{name} (line {line})")).collect();
            writeln!(f, "    {from} → {to}: {}", names.join(", "))?;
        }
        Ok(())
    }
}
