//! Names resolved to the file that defines them: a path (`crate::a::b::f`, `super::X`,
//! `child::Y`, a name brought in by a `use`) is followed module by module, through `use`
//! re-exports and glob imports, to the module whose own items hold its first item segment (or,
//! for an item of another crate, to the module whose `use` brings it into this one); a glob
//! import ties a file to the items of the glob that the file's code names.

use super::graph::Ties;
use super::tree::Tree;
use std::collections::{BTreeMap, BTreeSet};

/// What a path names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Res {
    /// A module (by id).
    Module(usize),
    /// An item `name` of the module `module`.
    Item { module: usize, name: String },
    /// Something outside the crate (another crate, the standard library, a prelude name).
    External,
}

/// Every (from, to) pair of files of `tree` where `from` names an item that `to` defines, with
/// the names.
pub(crate) fn edges(tree: &Tree) -> BTreeMap<(String, String), Ties> {
    let mut r = Resolver { tree, visiting: BTreeSet::new(), edges: BTreeMap::new() };
    for id in 0..tree.modules.len() {
        r.module_edges(id);
    }
    r.edges
}

struct Resolver<'t> {
    tree: &'t Tree,
    /// The (module, name) lookups under way: a glob that leads back ends there.
    visiting: BTreeSet<(usize, String)>,
    edges: BTreeMap<(String, String), Ties>,
}

impl<'t> Resolver<'t> {
    fn parent(&self, m: usize) -> Option<usize> {
        self.tree.modules.get(m).and_then(|md| md.parent)
    }

    fn root(&self, mut m: usize) -> usize {
        while let Some(p) = self.parent(m) {
            m = p;
        }
        m
    }

    fn file(&self, m: usize) -> Option<&'t str> {
        self.tree.modules.get(m).map(|md| md.file.as_str())
    }

    /// What `segs`, written in module `m`, names.
    fn resolve(&mut self, m: usize, segs: &[String]) -> Res {
        let Some(first) = segs.first() else { return Res::External };
        let mut cur = match first.as_str() {
            "crate" => self.root(m),
            "self" => m,
            "super" => match self.parent(m) {
                Some(p) => p,
                None => return Res::External,
            },
            "::" => return Res::External,
            name => match self.member(m, name, segs.len() == 1) {
                Some(Res::Module(x)) => x,
                Some(other) => return other,
                None => return Res::External,
            },
        };
        let mut rest = segs.get(1..).unwrap_or_default();
        while let Some((seg, tail)) = rest.split_first() {
            let found = if seg == "super" {
                Some(self.parent(cur).map_or(Res::External, Res::Module))
            } else {
                self.member(cur, seg, tail.is_empty())
            };
            match found {
                Some(Res::Module(x)) => cur = x,
                Some(other) => return other,
                // Not found among the module's own names (an item a macro makes, say): taken
                // to be the module's.
                None => return Res::Item { module: cur, name: seg.clone() },
            }
            rest = tail;
        }
        Res::Module(cur)
    }

    /// What `name` is inside module `m`: a child module, an item of its own, a name it imports,
    /// or a name one of its globs brings. `last`: nothing follows it in the path (an item is
    /// then preferred to a module of the same name).
    fn member(&mut self, m: usize, name: &str, last: bool) -> Option<Res> {
        if !self.visiting.insert((m, name.to_string())) {
            return None;
        }
        let found = self.member_uncached(m, name, last);
        self.visiting.remove(&(m, name.to_string()));
        found
    }

    fn member_uncached(&mut self, m: usize, name: &str, last: bool) -> Option<Res> {
        let tree: &'t Tree = self.tree;
        let md = tree.modules.get(m)?;
        let child = md.children.get(name).copied();
        if let (Some(c), false) = (child, last) {
            return Some(Res::Module(c));
        }
        if md.syntax.items.contains(name) {
            return Some(Res::Item { module: m, name: name.to_string() });
        }
        if let Some(c) = child {
            return Some(Res::Module(c));
        }
        let imports = &md.syntax.imports;
        if let Some(import) = imports.iter().find(|i| !i.glob && i.alias.as_deref() == Some(name)) {
            // Brought from another crate: this module's import is the one in the crate.
            return Some(match self.resolve(m, &import.segs) {
                Res::External => Res::Item { module: m, name: name.to_string() },
                inside => inside,
            });
        }
        for glob in imports.iter().filter(|i| i.glob) {
            if let Res::Module(g) = self.resolve(m, &glob.segs)
                && g != m
                && let Some(found) = self.member(g, name, last)
            {
                return Some(found);
            }
        }
        None
    }

    /// Ties `from` to the file of `module` by `name`, unless that is `from` itself.
    fn tie(&mut self, from: &str, module: usize, name: &str, line: usize) {
        let Some(to) = self.file(module) else { return };
        if to != from {
            let ties = self.edges.entry((from.to_string(), to.to_string())).or_default();
            ties.entry(name.to_string()).or_insert(line);
        }
    }

    /// The ties of module `m`'s imports and code paths.
    fn module_edges(&mut self, m: usize) {
        let tree: &'t Tree = self.tree;
        let Some(md) = tree.modules.get(m) else { return };
        let from = md.file.as_str();
        for import in &md.syntax.imports {
            match self.resolve(m, &import.segs) {
                Res::Item { module, name } => self.tie(from, module, &name, import.line),
                Res::Module(g) if import.glob => self.glob_edges(m, g),
                _ => {}
            }
        }
        for path in &md.syntax.paths {
            if let Res::Item { module, name } = self.resolve(m, &path.segs) {
                self.tie(from, module, &name, path.line);
            }
        }
    }

    /// The ties of a glob import of module `g` into `m`: each bare name of `m`'s code that `m`
    /// does not define or import by name, and that `g` supplies.
    fn glob_edges(&mut self, m: usize, g: usize) {
        let tree: &'t Tree = self.tree;
        let Some(md) = tree.modules.get(m) else { return };
        let from = md.file.as_str();
        for (name, &line) in &md.syntax.idents {
            let own = md.syntax.items.contains(name)
                || md.children.contains_key(name)
                || md.syntax.imports.iter().any(|i| !i.glob && i.alias.as_ref() == Some(name));
            if own || g == m {
                continue;
            }
            if let Some(Res::Item { module, name: item }) = self.member(g, name, true) {
                self.tie(from, module, &item, line);
            }
        }
    }
}
