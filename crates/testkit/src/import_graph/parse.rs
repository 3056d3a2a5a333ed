//! What one module's tokens say for the import graph: the items it defines, its `use`
//! declarations (brace groups and globs unfolded), the paths written in its code, the bare
//! names it uses, and its child modules (`mod x;` files, inline `mod x { … }` bodies).
//! Items under `#[cfg(test)]` and inline modules named `tests` are left out: test code may
//! import what it tests.

use super::lex::Tok;
use std::collections::{BTreeMap, BTreeSet};

/// One leaf of a `use` tree: `use a::b::{c as d, e::*}` gives `a::b::c` (named `d`) and
/// `a::b::e` (a glob).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Import {
    /// The path, from its first segment (`crate`, `super`, `self`, a name in scope, or `::`
    /// for a path from the extern prelude).
    pub segs: Vec<String>,
    /// The name it binds (the last segment, or the `as` name); `None` for `as _` and globs.
    pub alias: Option<String>,
    /// `path::*`.
    pub glob: bool,
    /// The line of its last segment.
    pub line: usize,
}

/// A path written in code (`crate::a::f`, `super::X`, `child::Y`), cut before any generic
/// arguments.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct PathRef {
    /// Its segments.
    pub segs: Vec<String>,
    /// The line of its first segment.
    pub line: usize,
}

/// One module's syntax.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct ModuleSyntax {
    /// Its name (`""` for a file's own module).
    pub name: String,
    /// The names of the items it defines (functions, types, traits, constants, statics, macros).
    pub items: BTreeSet<String>,
    /// Its `use` leaves, in order (those inside function bodies too).
    pub imports: Vec<Import>,
    /// The paths of two or more segments written in its code.
    pub paths: Vec<PathRef>,
    /// The bare identifiers used in its code (not after `.` or `::`, not bound or declared
    /// there), with the first line each is used on: what a glob import may supply.
    pub idents: BTreeMap<String, usize>,
    /// Its `mod x;` children, with the line.
    pub file_children: Vec<(String, usize)>,
    /// Its inline `mod x { … }` children.
    pub inline_children: Vec<ModuleSyntax>,
}

const KEYWORDS: [&str; 40] = [
    "as",
    "async",
    "await",
    "break",
    "const",
    "continue",
    "crate",
    "dyn",
    "else",
    "enum",
    "extern",
    "false",
    "fn",
    "for",
    "if",
    "impl",
    "in",
    "let",
    "loop",
    "match",
    "mod",
    "move",
    "mut",
    "pub",
    "ref",
    "return",
    "self",
    "Self",
    "static",
    "struct",
    "super",
    "trait",
    "true",
    "type",
    "unsafe",
    "use",
    "where",
    "while",
    "union",
    "macro_rules",
];

/// Tokens after which an identifier is not a use of a name in scope: a field or method, a
/// path's later segment, a binding, a declaration.
const NOT_A_USE_AFTER: [&str; 14] =
    [".", "::", "let", "mut", "fn", "struct", "enum", "mod", "trait", "type", "const", "static", "ref", "union"];

/// The tokens that start an item whose name follows.
const ITEM_KEYWORDS: [&str; 7] = ["fn", "struct", "enum", "trait", "type", "const", "static"];

fn text(toks: &[Tok], i: usize) -> &str {
    toks.get(i).map_or("", |t| t.text.as_str())
}

/// The index of the bracket closing the one at `open` (or the end of the tokens).
pub(crate) fn matching(toks: &[Tok], open: usize) -> usize {
    let mut depth = 0usize;
    for (k, t) in toks.iter().enumerate().skip(open) {
        match t.text.as_str() {
            "{" | "(" | "[" => depth += 1,
            "}" | ")" | "]" => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return k;
                }
            }
            _ => {}
        }
    }
    toks.len()
}

/// The syntax of a module whose body is `toks` (a whole file, or an inline module's braces'
/// inside).
pub(crate) fn module(toks: &[Tok], name: &str) -> ModuleSyntax {
    let mut m = ModuleSyntax { name: name.to_string(), ..ModuleSyntax::default() };
    let (mut i, mut depth, mut test_only) = (0usize, 0i32, false);
    while let Some(t) = toks.get(i) {
        if t.is("#") {
            if let Some((end, is_test)) = attribute(toks, i) {
                test_only |= is_test;
                i = end;
                continue;
            }
        } else if test_only {
            test_only = false;
            i = skip_item(toks, i);
            continue;
        }
        if let Some(next) = structure(toks, i, depth, &mut m) {
            i = next;
            continue;
        }
        if depth == 0
            && let Some(name) = item_name(toks, i)
        {
            m.items.insert(name);
        }
        match t.text.as_str() {
            "{" | "(" | "[" => depth += 1,
            "}" | ")" | "]" => depth -= 1,
            _ => {}
        }
        i = code(toks, i, &mut m);
    }
    m
}

/// A `use` declaration or a `mod` at `i`: recorded, and the index after it; else `None`.
fn structure(toks: &[Tok], i: usize, depth: i32, m: &mut ModuleSyntax) -> Option<usize> {
    let t = toks.get(i)?;
    if t.is("use") {
        return Some(use_declaration(toks, i + 1, &mut m.imports));
    }
    let name = toks.get(i + 1).filter(|n| t.is("mod") && n.ident)?;
    match text(toks, i + 2) {
        ";" => {
            if depth == 0 && !name.is("tests") {
                m.file_children.push((name.text.clone(), t.line));
            }
            Some(i + 3)
        }
        "{" => {
            let close = matching(toks, i + 2);
            if !name.is("tests") {
                let body = toks.get(i + 3..close).unwrap_or_default();
                m.inline_children.push(module(body, &name.text));
            }
            Some(close + 1)
        }
        _ => None,
    }
}

/// The token at `i` as code: a path, or a bare name. Returns the index of the next token to
/// read.
fn code(toks: &[Tok], i: usize, m: &mut ModuleSyntax) -> usize {
    let Some(t) = toks.get(i) else { return i + 1 };
    let prev = if i == 0 { "" } else { text(toks, i - 1) };
    if !t.ident || prev == "::" || t.is("Self") {
        return i + 1;
    }
    if text(toks, i + 1) == "::" && toks.get(i + 2).is_some_and(|n| n.ident) {
        let (segs, end) = path(toks, i);
        m.paths.push(PathRef { segs, line: t.line });
        return end;
    }
    let bound = NOT_A_USE_AFTER.contains(&prev) || text(toks, i + 1) == ":" || text(toks, i + 1) == "!";
    if !bound && !KEYWORDS.contains(&t.text.as_str()) {
        m.idents.entry(t.text.clone()).or_insert(t.line);
    }
    i + 1
}

/// The segments of the path starting at `i` (identifiers joined by `::`), and the index after.
fn path(toks: &[Tok], i: usize) -> (Vec<String>, usize) {
    let mut segs = Vec::new();
    let mut k = i;
    while let Some(t) = toks.get(k).filter(|t| t.ident) {
        segs.push(t.text.clone());
        if text(toks, k + 1) == "::" && toks.get(k + 2).is_some_and(|n| n.ident) {
            k += 2;
        } else {
            k += 1;
            break;
        }
    }
    (segs, k)
}

/// The name of the item that the keyword at `i` starts (`fn f`, `struct S`, `const fn g`,
/// `macro_rules! m`, `union U {`), if it starts one.
fn item_name(toks: &[Tok], i: usize) -> Option<String> {
    let t = toks.get(i)?;
    let mut k = i + 1;
    if (t.is("const") && text(toks, k) == "fn") || (t.is("macro_rules") && text(toks, k) == "!") {
        k += 1;
    } else if t.is("union") {
        if !matches!(text(toks, i + 2), "{" | "<") {
            return None;
        }
    } else if !ITEM_KEYWORDS.contains(&t.text.as_str()) {
        return None;
    }
    let name = toks.get(k).filter(|n| n.ident && n.text != "_" && !KEYWORDS.contains(&n.text.as_str()))?;
    Some(name.text.clone())
}

/// The attribute starting with the `#` at `i`: the index after its `]`, and whether it is an
/// outer `#[cfg(test)]`.
fn attribute(toks: &[Tok], i: usize) -> Option<(usize, bool)> {
    let inner = text(toks, i + 1) == "!";
    let open = if inner { i + 2 } else { i + 1 };
    if text(toks, open) != "[" {
        return None;
    }
    let close = matching(toks, open);
    let body: Vec<&str> = toks.get(open + 1..close).unwrap_or_default().iter().map(|t| t.text.as_str()).collect();
    Some((close + 1, !inner && body == ["cfg", "(", "test", ")"]))
}

/// The index after the item starting at `i`: at its `;`, or after its braced body (after the
/// `;` that follows an `=` and a braced value), or at an unmatched closing bracket.
fn skip_item(toks: &[Tok], i: usize) -> usize {
    let (mut k, mut assigned) = (i, false);
    while let Some(t) = toks.get(k) {
        match t.text.as_str() {
            ";" => return k + 1,
            "=" => assigned = true,
            "{" | "(" | "[" => {
                let close = matching(toks, k);
                if t.is("{") && !assigned {
                    return close + 1;
                }
                k = close;
            }
            "}" | ")" | "]" => return k,
            _ => {}
        }
        k += 1;
    }
    k
}

/// The leaves of the `use` declaration whose tree starts at `i`; the index after its `;`.
fn use_declaration(toks: &[Tok], i: usize, out: &mut Vec<Import>) -> usize {
    let end = use_tree(toks, i, Vec::new(), out);
    let mut k = end;
    while toks.get(k).is_some_and(|t| !t.is(";")) {
        k += 1;
    }
    k + 1
}

/// One use tree starting at `i` under `prefix`; its leaves into `out`. Returns the index after.
fn use_tree(toks: &[Tok], i: usize, mut prefix: Vec<String>, out: &mut Vec<Import>) -> usize {
    let mut k = i;
    loop {
        let Some(t) = toks.get(k) else { return k };
        match t.text.as_str() {
            "::" => {
                if prefix.is_empty() {
                    prefix.push("::".into());
                }
                k += 1;
            }
            "*" => {
                out.push(Import { segs: prefix, alias: None, glob: true, line: t.line });
                return k + 1;
            }
            "{" => return use_group(toks, k, &prefix, out),
            _ if t.ident => {
                if text(toks, k + 1) == "::" {
                    prefix.push(t.text.clone());
                    k += 2;
                    continue;
                }
                return use_leaf(toks, k, prefix, out);
            }
            _ => return k,
        }
    }
}

/// A `{ tree, tree, … }` group at `open` under `prefix`; the index after its `}`.
fn use_group(toks: &[Tok], open: usize, prefix: &[String], out: &mut Vec<Import>) -> usize {
    let close = matching(toks, open);
    let mut k = open + 1;
    while k < close {
        if text(toks, k) == "," {
            k += 1;
            continue;
        }
        k = use_tree(toks, k, prefix.to_vec(), out).max(k + 1);
    }
    close + 1
}

/// The leaf name at `k` (`x`, `self`, `x as y`, `x as _`); the index after it.
fn use_leaf(toks: &[Tok], k: usize, mut prefix: Vec<String>, out: &mut Vec<Import>) -> usize {
    let Some(t) = toks.get(k) else { return k };
    let mut alias = if t.is("self") { prefix.last().cloned() } else { Some(t.text.clone()) };
    if !t.is("self") {
        prefix.push(t.text.clone());
    }
    let mut end = k + 1;
    if text(toks, end) == "as" {
        alias = toks.get(end + 1).filter(|a| a.ident && !a.is("_")).map(|a| a.text.clone());
        end += 2;
    }
    out.push(Import { segs: prefix, alias, glob: false, line: t.line });
    end
}

#[cfg(test)]
mod tests {
    use super::super::lex::tokens;
    use super::*;

    fn parse(source: &str) -> ModuleSyntax {
        module(&tokens(source), "")
    }

    fn leaves(m: &ModuleSyntax) -> Vec<(String, Option<&str>, bool)> {
        m.imports.iter().map(|i| (i.segs.join("::"), i.alias.as_deref(), i.glob)).collect()
    }

    #[test]
    fn use_trees_unfold_with_braces_globs_renames_and_self() {
        let m =
            parse("pub(crate) use crate::a::{b::X, c::{self, Y as Z, w::*}, _T as _};\nuse ::ext::Q;\nuse super::*;");
        assert_eq!(
            leaves(&m),
            [
                ("crate::a::b::X".into(), Some("X"), false),
                ("crate::a::c".into(), Some("c"), false),
                ("crate::a::c::Y".into(), Some("Z"), false),
                ("crate::a::c::w".into(), None, true),
                ("crate::a::_T".into(), None, false),
                ("::::ext::Q".into(), Some("Q"), false),
                ("super".into(), None, true),
            ]
        );
    }

    #[test]
    fn items_paths_and_names_at_their_levels() {
        let m = parse(
            "pub const fn f() { let x = crate::a::g::<u8>(); h(x.len); }\nstruct S;\nimpl S { fn m() {} }\nmacro_rules! mac { () => {} }\nconst _: () = ();",
        );
        assert_eq!(m.items.iter().map(String::as_str).collect::<Vec<_>>(), ["S", "f", "mac"]);
        assert_eq!(m.paths, [PathRef { segs: vec!["crate".into(), "a".into(), "g".into()], line: 1 }]);
        assert!(m.idents.contains_key("h") && m.idents.contains_key("u8"));
        // Not after `.` (a field or method) or a declaring keyword.
        assert!(!m.idents.contains_key("len") && !m.idents.contains_key("m"));
    }

    #[test]
    fn test_code_is_left_out_and_children_are_found() {
        let m = parse(
            "mod a;\npub mod b { mod c; pub fn inner() {} }\n#[cfg(test)]\nmod d;\n#[cfg(test)]\nfn helper() { crate::x::y(); }\n#[cfg(test)]\nmod tests { use crate::z::W; }\nmod tests;\nfn after() {}",
        );
        assert_eq!(m.file_children, [("a".to_string(), 1)]);
        assert_eq!(m.inline_children.len(), 1);
        assert_eq!(m.inline_children[0].file_children, [("c".to_string(), 2)]);
        assert!(m.inline_children[0].items.contains("inner"));
        assert!(m.paths.is_empty() && m.imports.is_empty(), "{m:?}");
        assert!(m.items.contains("after") && !m.items.contains("helper"));
    }
}
