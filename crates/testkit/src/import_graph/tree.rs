//! A crate's module tree, read from its roots (`src/lib.rs`, `src/main.rs`) through its `mod x;`
//! declarations: which file each module's code is in, and each module's parent and children.
//! `lib.rs`, `main.rs` and `mod.rs` own the files of their folder; `a.rs` owns `a/`; an inline
//! `mod m { mod x; }` owns the folder `m/` of its file's. Files named `tests.rs` are left out.

use super::lex::tokens;
use super::parse::{ModuleSyntax, module};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One module.
#[derive(Clone, Debug)]
pub(crate) struct Module {
    /// The file its code is in, relative to `src/`.
    pub file: String,
    /// The module it is declared in (`None` for a crate root).
    pub parent: Option<usize>,
    /// Its child modules by name.
    pub children: BTreeMap<String, usize>,
    /// Its own syntax (its children's taken out).
    pub syntax: ModuleSyntax,
}

/// Every module of a crate.
#[derive(Clone, Debug, Default)]
pub(crate) struct Tree {
    /// The modules; a module's index is its id.
    pub modules: Vec<Module>,
    /// Every file read, relative to `src/`.
    pub files: BTreeSet<String>,
    /// The `mod x;` declarations whose file was found nowhere.
    pub missing: Vec<String>,
}

impl Tree {
    /// For each file, the files of the modules enclosing its own (its parent's, …, the crate
    /// root's), itself left out.
    pub fn enclosing(&self) -> BTreeMap<String, BTreeSet<String>> {
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for m in &self.modules {
            let around = out.entry(m.file.clone()).or_default();
            let mut parent = m.parent;
            while let Some(p) = parent.and_then(|p| self.modules.get(p)) {
                if p.file != m.file {
                    around.insert(p.file.clone());
                }
                parent = p.parent;
            }
        }
        out
    }
}

/// `dir/name`, or `name` in the folder `""`.
fn join(dir: &str, name: &str) -> String {
    if dir.is_empty() { name.to_string() } else { format!("{dir}/{name}") }
}

/// The module tree of the crate whose `src/` folder is `src`.
pub(crate) fn load(src: &Path) -> std::io::Result<Tree> {
    let mut tree = Tree::default();
    for root in ["lib.rs", "main.rs"] {
        if src.join(root).is_file() {
            load_file(&mut tree, src, root, None, "")?;
        }
    }
    Ok(tree)
}

/// Reads the file `rel` as the module `name` of `parent`.
fn load_file(tree: &mut Tree, src: &Path, rel: &str, parent: Option<usize>, name: &str) -> std::io::Result<()> {
    if !tree.files.insert(rel.to_string()) {
        return Ok(());
    }
    let text = std::fs::read_to_string(src.join(rel))?;
    let syntax = module(&tokens(&text), name);
    let (folder, file_name) = rel.rsplit_once('/').unwrap_or(("", rel));
    let children_dir = if matches!(file_name, "lib.rs" | "main.rs" | "mod.rs") {
        folder.to_string()
    } else {
        rel.trim_end_matches(".rs").to_string()
    };
    add(tree, src, syntax, rel, parent, &children_dir)
}

/// Adds the module `syntax` (in `file`, its children's files in `children_dir`) under `parent`,
/// and its children.
fn add(
    tree: &mut Tree,
    src: &Path,
    mut syntax: ModuleSyntax,
    file: &str,
    parent: Option<usize>,
    children_dir: &str,
) -> std::io::Result<()> {
    let inline = std::mem::take(&mut syntax.inline_children);
    let declared = std::mem::take(&mut syntax.file_children);
    let id = tree.modules.len();
    let name = syntax.name.clone();
    tree.modules.push(Module { file: file.to_string(), parent, children: BTreeMap::new(), syntax });
    if let Some(p) = parent.and_then(|p| tree.modules.get_mut(p)) {
        p.children.insert(name, id);
    }
    for child in inline {
        let dir = join(children_dir, &child.name);
        add(tree, src, child, file, Some(id), &dir)?;
    }
    for (child, line) in declared {
        let candidates = [join(children_dir, &format!("{child}.rs")), join(children_dir, &format!("{child}/mod.rs"))];
        match candidates.iter().find(|c| src.join(c).is_file()) {
            Some(found) if found.rsplit('/').next() == Some("tests.rs") => {}
            Some(found) => load_file(tree, src, found, Some(id), &child)?,
            None => tree
                .missing
                .push(format!("{file}:{line}: mod {child}: neither {} nor {}", candidates[0], candidates[1])),
        }
    }
    Ok(())
}
