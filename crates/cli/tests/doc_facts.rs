//! The checkable facts of every doc (`README.md` and `docs/*.md`) held against the repository
//! and the code, so that prose cannot drift where no other test reads it. `docs/cli.md` is not
//! read for facts (it is the binary's own help, held by `cli_doc.rs`): it is the truth for the
//! commands and flags. Every failure is reported at once, as `file:line: kind: what`; with
//! `-- --nocapture` the test also prints how many facts of each kind it checked and every fact
//! it read but did not check, with why.
//!
//! What is read: *code* is a backtick span (it may run over a line break) or a line of a fenced
//! block; *prose* is the rest, as words (`;`, `.`, a bracket and a table's `|` break a clause).
//!
//! 1. **Paths.** Every token starting with `crates/`, `worlds/`, `tests/`, `docs/`, `fuzz/`,
//!    `.ci/` or `robots/` (not glued to a path character before it; in code or
//!    prose), with trailing `.,:;` stripped and `{a,b}` groups expanded, exists in the repository
//!    (a folder when it ends with `/`). Backtick spans ending in `.rs` without such a prefix
//!    (`paper/icp.rs`, `params.rs`), and `tests/...` paths that are not at the root, are
//!    *crate-relative*: some file of the repository ends with `/<path>`. Not repository paths,
//!    listed as not checked: globs and placeholders (a `*`, `<` or `>` in the path; output
//!    folders such as `results/`, `OUT/` or `runs/` start with no prefix above) and the short
//!    list [`NOT_IN_REPO`], each entry with why (an entry no doc writes any more fails).
//! 2. **Commands.** In code, `mapkeeper <word> [<word>]` (also `target/release/mapkeeper ...`,
//!    and `cargo run ... -- <word>` without `-p`, `--bin` or `--example`), outside `#` comments
//!    of fenced blocks, and a backtick span starting with a command that has subcommands and a
//!    word (`experiment kidnap-robot`): the first word is a command of `docs/cli.md`'s
//!    `## \`mapkeeper ...\`` headings, and when that command has subcommands, the second word is
//!    one of them (or a clap alias). The table of `docs/commands.md` lists every top-level
//!    command once. `cargo ... -p <package>` names a workspace package, and its `--bench` /
//!    `--example` / `--test <name>` a target file of that package.
//! 3. **Flags.** Every `--flag` in code is a flag the binary defines in some section of
//!    `docs/cli.md`, or is listed in [`FOREIGN_FLAGS`] with its tool (an entry must be written
//!    in some doc, must not be a flag of the binary, and when its tool is a file of the
//!    repository, that file must contain it); `--flag` itself stands for any flag. A flag after
//!    `mapkeeper CMD [SUB]` in the same code (a fenced line continues the one before when that
//!    ends with `\` or it is indented deeper), or in a backtick span that starts with a
//!    command's name (`validate --shard k/N`), is a flag of that command's section. Flags in
//!    prose outside backticks, and single-dash flags (`-p`, `-D`), are not checked; nor is a
//!    flag in one span against a command named in another span of the line (prose names a
//!    command and then another's or another tool's flag too often).
//! 4. **Presets.** A backtick name next to the word preset(s) (`` `paper` preset ``, ``presets
//!    `a`, `b` and `c` ``) is an updater or localiser preset (`PRESET_NAMES`,
//!    `LOCALISER_PRESETS`: the one the word `updater` / `localiser` beside it names, else either),
//!    a backtick name before the word `localiser` is a localiser preset, the values of
//!    `--preset(s)` and `--localiser(s)` in code (not in comments) are presets of their kind
//!    (`--localiser` also `auto`; upper-case and one-letter placeholders such as `P` or `a,b`
//!    are skipped), and so are the names in a fenced `::preset("…")`.
//!    **Counts**: `N localiser presets`, `N updater presets`, `all N presets`, `the N presets`
//!    (not the possessive `the two presets'`), `of the N presets`, `N presets of
//!    \`PRESET_NAMES\``, `N presets (\`--localiser\` …)`, `the localiser has N presets` are the
//!    real count (unqualified: the updater's, the presets of `--preset`); `the N commands` the
//!    top-level commands; `workspace of N crates`, `all N crates`, `the N crates` the folders
//!    with a `crates/*/Cargo.toml`. A count under a dated heading (one that names an issue, a
//!    commit or a date, or starts with `Earlier`) is of its time: listed as not checked. Other
//!    counts ("Six presets run the updater's algorithm", "2 presets × seed 11") count a subset
//!    and are not read. `docs/ARCHITECTURE.md` names every crate's folder (`(crates/x)`).
//! 5. **Rust names.** A backtick span that is a Rust path (`harness::run`,
//!    `UpdaterParams::validate`) or a call (`change_state_bytes()`, `f(a, b)`: the callee): each
//!    segment is an identifier of the repository's Rust code (comments left out; not this file)
//!    or a crate's short name; a path into another crate (`std::…`, a crate of `Cargo.lock`) is
//!    listed as not checked, and so are the few names of [`FOREIGN_NAMES`] (C++ of ROS, the
//!    paper's notation). Fenced Rust blocks are not read.
//!
//! Each kind must reach a floor of facts checked (a parser that stops finding them fails), and
//! the extractors are tested on small strings below.
#![allow(clippy::unwrap_used)]

use mapkeeper_localiser::LOCALISER_PRESETS;
use mapkeeper_updater::PRESET_NAMES;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The starts of a repository path.
const PREFIXES: [&str; 7] = ["crates/", "worlds/", "tests/", "docs/", "fuzz/", ".ci/", "robots/"];

/// Paths with a repository prefix that are not in the repository by design, with why.
const NOT_IN_REPO: [(&str, &str); 2] = [
    ("worlds/W_001.toml", "a world of the set `mapkeeper generate` writes into its output folder"),
    ("worlds/w.toml", "the file named in docs/world-format.md's sample error messages"),
];

/// Flags of other tools written in the docs, with the tool (none is a flag of the binary; a
/// tool that is a file of the repository must contain the flag).
const FOREIGN_FLAGS: [(&str, &str); 27] = [
    ("--release", "cargo"),
    ("--selftest", "crates/node/tests/cyclone/drive.py"),
    ("--bag", "crates/node/tests/cyclone/drive.py"),
    ("--no-pose", "crates/node/tests/cyclone/drive.py"),
    ("--workspace", "cargo"),
    ("--locked", "cargo"),
    ("--test", "cargo"),
    ("--bench", "cargo"),
    ("--example", "cargo"),
    ("--path", "cargo install"),
    ("--profile-time", "criterion, after `cargo bench ... --`"),
    ("--warmup", "farm-bench (the machine's paired-run timer)"),
    ("--vs", "farm-bench"),
    ("--timeout", "farm-bench and kubectl wait"),
    ("--call-graph", "perf record"),
    ("--tool", "valgrind"),
    ("--toggle-collect", "valgrind (callgrind)"),
    ("--array", "sbatch"),
    ("--dependency", "sbatch"),
    ("--wrap", "sbatch"),
    ("--for", "kubectl wait"),
    ("--laps", "crates/updater/examples/cpu_time.rs"),
    ("--no-digest", "crates/updater/examples/cpu_time.rs"),
    ("--scans", "crates/localiser/examples/soak.rs"),
    ("--every", "crates/localiser/examples/soak.rs"),
    ("--expect-model", "crates/localiser/benches/nav2_amcl_compare.py"),
    ("--ours", "crates/localiser/benches/nav2_amcl_compare.py"),
];

/// Names written as Rust paths or calls that are not Rust of this repository, with what they are.
const FOREIGN_NAMES: [(&str, &str); 4] = [
    ("amcl_node", "Nav2's amcl (C++)"),
    ("laserReceived", "Nav2's amcl (C++)"),
    ("LikelihoodFieldModel", "ROS 1 amcl's amcl_laser.cpp"),
    ("D_th", "the paper's notation (eq. 9)"),
];

/// The number words a count is written in.
const NUMBERS: &str = "zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen \
                       sixteen seventeen eighteen nineteen twenty";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

// ---------------------------------------------------------------------------------------------
// Reading a doc

/// A doc: its name as written in the repository and its lines.
struct Doc {
    name: String,
    lines: Vec<String>,
}

impl Doc {
    fn new(name: &str, text: &str) -> Doc {
        Doc { name: name.to_string(), lines: text.lines().map(str::to_string).collect() }
    }
}

/// A piece of prose: a word (lower case, punctuation trimmed) or a backtick span (verbatim).
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String),
    Span(String),
}

/// Code: a backtick span, or a line of a fenced block (`cont`: it continues the line before).
#[derive(Debug, Clone)]
struct Code {
    line: usize,
    text: String,
    fenced: bool,
    cont: bool,
}

/// A doc read: its prose tokens and code, each with its line, and each line's heading.
struct Parsed {
    toks: Vec<(usize, Tok)>,
    code: Vec<Code>,
    heading: Vec<String>,
}

/// A clause break between tokens (`;`, `.`, a bracket, a table's `|`): no preset list or
/// `` `name` preset `` runs over it.
const BREAK: &str = "|";

fn push_word(word: &mut String, line: usize, toks: &mut Vec<(usize, Tok)>) {
    let brk = |toks: &mut Vec<(usize, Tok)>| toks.push((line, Tok::Word(BREAK.to_string())));
    if word.starts_with(['(', '|']) {
        brk(toks);
    }
    let w = word.trim_matches(|c: char| !c.is_alphanumeric() && c != '\'').trim_start_matches('\'');
    if !w.is_empty() {
        toks.push((line, Tok::Word(w.to_lowercase())));
    }
    if word.ends_with([';', '.', ')']) {
        brk(toks);
    }
    word.clear();
}

/// One line of prose: words, and spans (`span` holds one open over a line break).
fn prose_line(n: usize, line: &str, span: &mut Option<(usize, String)>, p: &mut Parsed) {
    let mut word = String::new();
    for c in line.chars() {
        if c == '`' {
            if let Some((l, s)) = span.take() {
                p.toks.push((l, Tok::Span(s.clone())));
                p.code.push(Code { line: l, text: s, fenced: false, cont: false });
            } else {
                push_word(&mut word, n, &mut p.toks);
                *span = Some((n, String::new()));
            }
        } else if let Some((_, s)) = span.as_mut() {
            s.push(c);
        } else if c.is_whitespace() {
            push_word(&mut word, n, &mut p.toks);
        } else {
            word.push(c);
        }
    }
    push_word(&mut word, n, &mut p.toks);
    if let Some((_, s)) = span.as_mut() {
        s.push(' ');
    }
}

fn parse(doc: &Doc) -> Parsed {
    let mut p = Parsed { toks: Vec::new(), code: Vec::new(), heading: Vec::new() };
    let (mut fence, mut base, mut backslash) = (false, None, false);
    let mut span: Option<(usize, String)> = None;
    let mut heading = String::new();
    for (i, line) in doc.lines.iter().enumerate() {
        let n = i + 1;
        let trimmed = line.trim_start();
        if !fence && trimmed.starts_with('#') {
            heading = trimmed.to_string();
        }
        p.heading.push(heading.clone());
        if trimmed.starts_with("```") {
            (fence, base, backslash, span) = (!fence, None, false, None);
        } else if fence {
            let indent = line.len() - trimmed.len();
            let cont = backslash || base.is_some_and(|b| indent > b);
            base = base.or(Some(indent));
            backslash = line.trim_end().ends_with('\\');
            p.code.push(Code { line: n, text: line.clone(), fenced: true, cont });
        } else if line.trim().is_empty() {
            span = None;
        } else {
            prose_line(n, line, &mut span, &mut p);
        }
    }
    p
}

/// The docs read for facts: `README.md` and `docs/*.md` but the generated `docs/cli.md`.
fn docs() -> Vec<Doc> {
    let mut names: Vec<String> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md") && n != "cli.md")
        .map(|n| format!("docs/{n}"))
        .collect();
    names.sort();
    names.insert(0, "README.md".to_string());
    names.iter().map(|n| Doc::new(n, &std::fs::read_to_string(root().join(n)).unwrap())).collect()
}

// ---------------------------------------------------------------------------------------------
// The truth

/// `docs/cli.md`: each section's command words (after `mapkeeper`) and the flags it defines.
struct Cli {
    sections: BTreeMap<Vec<String>, BTreeSet<String>>,
    /// Subcommand aliases (`[alias: table1]`): (command, alias) → the subcommand.
    aliases: BTreeMap<(String, String), String>,
}

/// The flag a line of help defines (`      --seeds <K>`, `  -h, --help`), if it defines one.
fn defined_flag(line: &str) -> Option<String> {
    let t = line.trim_start();
    let t = match t.get(2..4) {
        Some(", ") if t.starts_with('-') => &t[4..],
        _ => t,
    };
    t.starts_with("--").then(|| flag_name(t)).flatten()
}

impl Cli {
    fn parse(md: &str) -> Cli {
        let mut cli = Cli { sections: BTreeMap::new(), aliases: BTreeMap::new() };
        let mut key: Vec<String> = Vec::new();
        for line in md.lines() {
            if let Some(title) = line.strip_prefix("## `mapkeeper").and_then(|t| t.strip_suffix('`')) {
                key = title.split_whitespace().map(str::to_string).collect();
                cli.sections.entry(key.clone()).or_default();
            } else if let Some(flag) = defined_flag(line) {
                cli.sections.entry(key.clone()).or_default().insert(flag);
            } else if let (Some(cmd), Some((_, alias))) = (key.first(), line.split_once("[alias: ")) {
                let sub = line.split_whitespace().next().unwrap().to_string();
                cli.aliases.insert((cmd.clone(), alias.trim_end_matches(']').to_string()), sub);
            }
        }
        cli
    }

    fn top(&self) -> Vec<&str> {
        self.sections.keys().filter(|k| k.len() == 1).map(|k| k[0].as_str()).collect()
    }

    fn has_subs(&self, cmd: &str) -> bool {
        self.sections.keys().any(|k| k.len() == 2 && k[0] == cmd)
    }

    fn all_flags(&self) -> BTreeSet<&str> {
        self.sections.values().flatten().map(String::as_str).collect()
    }

    /// The section a command's words name (`["experiment", "table1"]` → its subcommand's).
    fn section(&self, words: &[String]) -> Option<Vec<String>> {
        let first = words.first()?;
        if !self.sections.contains_key(&vec![first.clone()]) {
            return None;
        }
        if let Some(second) = words.get(1).filter(|_| self.has_subs(first)) {
            let sub = self.aliases.get(&(first.clone(), second.clone())).unwrap_or(second);
            let key = vec![first.clone(), sub.clone()];
            return self.sections.contains_key(&key).then_some(key);
        }
        Some(vec![first.clone()])
    }
}

/// What the docs are held against.
struct Truth {
    root: PathBuf,
    /// Every file of the repository, relative to the root (`/`-separated).
    files: BTreeSet<String>,
    cli: Cli,
    /// Workspace packages by name → their folder (`crates/<dir>`).
    packages: BTreeMap<String, String>,
    /// Every identifier in the repository's Rust code (comments left out).
    idents: BTreeSet<String>,
    /// Crates not of this repository (`Cargo.lock`'s, `std`, `core`, `alloc`), as Rust names.
    external: BTreeSet<String>,
}

fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy();
        if p.is_dir() && name != ".git" && name != "target" {
            walk(root, &p, out);
        } else if p.is_file() {
            out.insert(p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"));
        }
    }
}

impl Truth {
    fn load(cli_md: &str) -> Truth {
        let root = root();
        let mut files = BTreeSet::new();
        walk(&root, &root, &mut files);
        let mut packages = BTreeMap::new();
        for f in files.iter().filter(|f| f.starts_with("crates/") && f.matches('/').count() == 2) {
            if let Some(dir) = f.strip_suffix("/Cargo.toml") {
                let toml = std::fs::read_to_string(root.join(f)).unwrap();
                let line = toml.lines().find(|l| l.starts_with("name = ")).unwrap();
                packages.insert(line[7..].trim_matches('"').to_string(), dir.to_string());
            }
        }
        let mut idents = BTreeSet::new();
        // (Not this file: its tests write wrong names on purpose.)
        for f in files.iter().filter(|f| f.ends_with(".rs") && *f != "crates/cli/tests/doc_facts.rs") {
            for line in std::fs::read_to_string(root.join(f)).unwrap().lines() {
                let code = line.split("//").next().unwrap();
                idents.extend(code.split(|c: char| !c.is_ascii_alphanumeric() && c != '_').map(str::to_string));
            }
        }
        // Our crates by their short names too (`harness::run`).
        idents.extend(packages.values().map(|d| d.trim_start_matches("crates/").replace('-', "_")));
        let lock = std::fs::read_to_string(root.join("Cargo.lock")).unwrap();
        let mut external: BTreeSet<String> = ["std", "core", "alloc"].map(String::from).into();
        external.extend(
            lock.lines()
                .filter_map(|l| l.strip_prefix("name = \""))
                .filter(|n| !n.starts_with("mapkeeper"))
                .map(|n| n.trim_end_matches('"').replace('-', "_")),
        );
        Truth { root, files, cli: Cli::parse(cli_md), packages, idents, external }
    }
}

// ---------------------------------------------------------------------------------------------
// The report

#[derive(Default)]
struct Report {
    failures: Vec<String>,
    /// Facts checked, by kind.
    seen: BTreeMap<&'static str, usize>,
    /// Facts written but not checked, with why.
    skipped: Vec<String>,
    /// Entries of `NOT_IN_REPO`, `FOREIGN_FLAGS` and `FOREIGN_NAMES` met.
    used: BTreeSet<String>,
}

impl Report {
    fn check(&mut self, kind: &'static str, ok: bool, at: (&Doc, usize), what: impl FnOnce() -> String) {
        *self.seen.entry(kind).or_default() += 1;
        if !ok {
            self.failures.push(format!("{}:{}: {kind}: {}", at.0.name, at.1, what()));
        }
    }

    fn skip(&mut self, at: (&Doc, usize), what: String) {
        self.skipped.push(format!("{}:{}: {what}", at.0.name, at.1));
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Paths

fn path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || "_./*<>-".contains(c)
}

/// The repository-prefixed paths written on a line, braces unexpanded, trailing `.,:;` stripped.
fn paths_in(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let chars: Vec<(usize, char)> = line.char_indices().collect();
    for (k, &(i, _)) in chars.iter().enumerate() {
        let boundary = k == 0 || !(path_char(chars[k - 1].1) || "{},".contains(chars[k - 1].1));
        if !boundary || !PREFIXES.iter().any(|p| line[i..].starts_with(p)) {
            continue;
        }
        let (mut path, mut depth) = (String::new(), 0);
        for &(_, c) in &chars[k..] {
            match c {
                '{' => depth += 1,
                '}' if depth > 0 => depth -= 1,
                ',' if depth > 0 => {}
                c if path_char(c) => {}
                _ => break,
            }
            path.push(c);
        }
        out.push(path.trim_end_matches(['.', ',', ':', ';']).to_string());
    }
    out
}

/// `a/{b,c}.rs` → `a/b.rs`, `a/c.rs` (every group).
fn expand(p: &str) -> Vec<String> {
    match (p.find('{'), p.find('}')) {
        (Some(a), Some(b)) if a < b => {
            p[a + 1..b].split(',').flat_map(|alt| expand(&format!("{}{alt}{}", &p[..a], &p[b + 1..]))).collect()
        }
        _ => vec![p.to_string()],
    }
}

/// Whether a (brace-free) path is in the repository, at the root or, crate-relative, under it.
fn exists(truth: &Truth, p: &str) -> bool {
    let (rel, folder) = (p.trim_end_matches('/'), p.ends_with('/'));
    let at = truth.root.join(rel);
    if at.exists() && (!folder || at.is_dir()) {
        return true;
    }
    let crate_relative = p.starts_with("tests/") || !PREFIXES.iter().any(|x| p.starts_with(x));
    let (file_end, folder_in) = (format!("/{rel}"), format!("/{rel}/"));
    crate_relative && truth.files.iter().any(|f| (!folder && f.ends_with(&file_end)) || f.contains(&folder_in))
}

/// A backtick span that is a crate-relative source path (`paper/icp.rs`, `params.rs`).
fn crate_relative_rs(span: &str) -> bool {
    span.ends_with(".rs")
        && !PREFIXES.iter().any(|p| span.starts_with(p))
        && span.chars().all(|c| path_char(c) || "{},".contains(c))
}

fn check_path(doc: &Doc, line: usize, p: &str, truth: &Truth, r: &mut Report) {
    if p.contains(['*', '<', '>']) {
        return r.skip((doc, line), format!("`{p}`: a glob or placeholder"));
    }
    if let Some((_, why)) = NOT_IN_REPO.iter().find(|(q, _)| *q == p) {
        r.used.insert(p.to_string());
        return r.skip((doc, line), format!("`{p}`: {why}"));
    }
    for one in expand(p) {
        r.check("path", exists(truth, &one), (doc, line), || format!("`{one}` is not in the repository"));
    }
}

fn check_paths(doc: &Doc, parsed: &Parsed, truth: &Truth, r: &mut Report) {
    for (i, line) in doc.lines.iter().enumerate() {
        for p in paths_in(line) {
            check_path(doc, i + 1, &p, truth, r);
        }
    }
    for c in parsed.code.iter().filter(|c| !c.fenced && crate_relative_rs(c.text.trim())) {
        check_path(doc, c.line, c.text.trim(), truth, r);
    }
}

// ---------------------------------------------------------------------------------------------
// 2, 3. Commands and flags

/// The tokens of a line of code, quotes and brackets trimmed.
fn code_tokens(text: &str) -> Vec<String> {
    text.split_whitespace()
        .map(|t| t.trim_matches(|c: char| "'\"[](){}|,;".contains(c)).to_string())
        .filter(|t| !t.is_empty())
        .collect()
}

fn is_word(t: &str) -> bool {
    t.starts_with(|c: char| c.is_ascii_lowercase())
        && t.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
}

/// `--name` of a token that is a long flag (`--array=1-10` → `--array`).
fn flag_name(t: &str) -> Option<String> {
    let rest = t.strip_prefix("--")?;
    if !rest.starts_with(|c: char| c.is_ascii_lowercase()) {
        return None;
    }
    let name: String = rest.chars().take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '-').collect();
    Some(format!("--{name}"))
}

/// The binary's invocations in a line of code's tokens: (index of the first command word, the
/// command words: up to two).
fn invocations(toks: &[String]) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let words = |from: usize| toks[from..].iter().take(2).take_while(|t| is_word(t)).cloned().collect::<Vec<_>>();
    for (i, t) in toks.iter().enumerate() {
        if (t == "mapkeeper" || t.ends_with("/mapkeeper")) && toks.get(i + 1).is_some_and(|w| is_word(w)) {
            out.push((i + 1, words(i + 1)));
        }
        if t == "cargo" && toks.get(i + 1).is_some_and(|r| r == "run") {
            let dd = toks[i..].iter().position(|x| x == "--").map(|k| k + i);
            let other = |k: usize| toks[i..k].iter().any(|x| x == "--example" || x == "--bin" || x == "-p");
            if let Some(k) = dd.filter(|&k| !other(k) && toks.get(k + 1).is_some_and(|w| is_word(w))) {
                out.push((k + 1, words(k + 1)));
            }
        }
    }
    out
}

/// Checks a command's words; returns the section its flags belong to.
fn check_command(words: &[String], at: (&Doc, usize), truth: &Truth, r: &mut Report) -> Option<Vec<String>> {
    let cli = &truth.cli;
    let section = cli.section(words);
    let shown = words.iter().take(if cli.has_subs(&words[0]) { 2 } else { 1 }).cloned().collect::<Vec<_>>();
    r.check("command", section.is_some(), at, || format!("`mapkeeper {}` is not a command", shown.join(" ")));
    section
}

/// `cargo ... -p <package> [--bench|--example|--test <name>]`: the package and its target exist.
fn check_cargo(toks: &[String], at: (&Doc, usize), truth: &Truth, r: &mut Report) {
    let Some(c) = toks.iter().position(|t| t == "cargo") else { return };
    let end = toks[c..].iter().position(|t| t == "--" || t == "&&").map_or(toks.len(), |k| k + c);
    let toks = &toks[c..end];
    let Some(pkg) = toks.iter().position(|t| t == "-p").and_then(|k| toks.get(k + 1)) else { return };
    let dir = truth.packages.get(pkg);
    r.check("cargo target", dir.is_some(), at, || format!("`-p {pkg}` is not a workspace package"));
    for (flag, folder) in [("--bench", "benches"), ("--example", "examples"), ("--test", "tests")] {
        if let (Some(dir), Some(name)) = (dir, toks.iter().position(|t| t == flag).and_then(|k| toks.get(k + 1))) {
            let ok = [format!("{dir}/{folder}/{name}.rs"), format!("{dir}/{folder}/{name}/main.rs")]
                .iter()
                .any(|f| truth.files.contains(f));
            r.check("cargo target", ok, at, || format!("`{flag} {name}`: no such target in {dir}/{folder}/"));
        }
    }
}

/// The preset kind a flag's value names, if it names presets.
fn preset_flag(flag: &str) -> Option<Kind> {
    match flag {
        "--preset" | "--presets" => Some(Kind::Updater),
        "--localiser" | "--localisers" => Some(Kind::Localiser),
        _ => None,
    }
}

fn check_flag(flag: &str, section: Option<&Vec<String>>, at: (&Doc, usize), truth: &Truth, r: &mut Report) {
    let cli = &truth.cli;
    if flag == "--flag" {
        return r.skip(at, "`--flag`: a placeholder for any flag".to_string());
    }
    if let Some((_, tool)) = FOREIGN_FLAGS.iter().find(|(f, _)| *f == flag) {
        r.used.insert(flag.to_string());
        if section.is_none() {
            return r.skip(at, format!("`{flag}`: {tool}'s"));
        }
    }
    match section {
        Some(s) => r.check("flag", cli.sections[s].contains(flag), at, || {
            format!("`{flag}` is not a flag of `mapkeeper {}`", s.join(" "))
        }),
        None => r.check("flag", cli.all_flags().contains(flag), at, || format!("`{flag}` is not a flag of mapkeeper")),
    }
}

/// One piece of code: its commands, cargo targets, flags and the presets flags name.
fn check_code(
    doc: &Doc,
    c: &Code,
    inherited: Option<Vec<String>>,
    truth: &Truth,
    r: &mut Report,
) -> Option<Vec<String>> {
    let at = (doc, c.line);
    let code = if c.fenced { c.text.split(" #").next().unwrap() } else { &c.text };
    let code = if code.trim_start().starts_with('#') { "" } else { code };
    let (toks, code) = (code_tokens(&c.text), code_tokens(code));
    let mut starts: Vec<(usize, Option<Vec<String>>)> = Vec::new();
    for (i, words) in invocations(&code) {
        starts.push((i, check_command(&words, at, truth, r)));
    }
    check_cargo(&toks, at, truth, r);
    // A span that starts with a command's name (`validate --shard k/N`, `experiment kidnap-robot`).
    let first = toks.first().filter(|t| !c.fenced && truth.cli.top().contains(&t.as_str()));
    let bare = first.and_then(|cmd| {
        let words: Vec<String> = toks.iter().take(2).take_while(|w| is_word(w)).cloned().collect();
        if truth.cli.has_subs(cmd) && words.len() == 2 {
            check_command(&words, at, truth, r)
        } else {
            truth.cli.section(&words)
        }
    });
    let mut section = if c.fenced { inherited.filter(|_| c.cont) } else { bare };
    for (i, t) in toks.iter().enumerate() {
        if let Some((_, s)) = starts.iter().find(|(k, _)| *k == i) {
            section = s.clone();
        }
        let Some(flag) = flag_name(t) else { continue };
        check_flag(&flag, section.as_ref(), at, truth, r);
        // A preset flag's value, outside comments; one-letter values (`a,b`) are placeholders.
        let value = t.split_once('=').map(|(_, v)| v.to_string()).or_else(|| code.get(i + 1).cloned());
        if let (Some(kind), Some(v)) = (preset_flag(&flag), value.filter(|_| i < code.len())) {
            for name in v.split([',', '|']).filter(|n| is_word(n) && n.len() > 1) {
                check_preset(name, Some(kind), at, r);
            }
        }
    }
    section
}

fn check_commands(doc: &Doc, parsed: &Parsed, truth: &Truth, r: &mut Report) {
    // The section the last fenced line ended in, for the next line if that continues it. (A
    // later span of the same line of prose does not inherit: prose names a command and then
    // another tool's or command's flag too often.)
    let mut section = None;
    for c in &parsed.code {
        section = check_code(doc, c, section.take(), truth, r).filter(|_| c.fenced);
    }
}

/// `docs/commands.md`'s table lists each top-level command once.
fn check_command_table(doc: &Doc, truth: &Truth, r: &mut Report) {
    let mut listed = BTreeMap::new();
    for (i, line) in doc.lines.iter().enumerate() {
        if let Some(cmd) = line.strip_prefix("| `").and_then(|l| l.split_once("` |")).map(|(c, _)| c) {
            let ok = truth.cli.top().contains(&cmd) && listed.insert(cmd.to_string(), i + 1).is_none();
            r.check("command", ok, (doc, i + 1), || format!("`{cmd}` in the table: not a command, or listed twice"));
        }
    }
    for cmd in truth.cli.top() {
        r.check("command", listed.contains_key(cmd), (doc, 1), || format!("the table lacks `{cmd}`"));
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Presets and counts

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Updater,
    Localiser,
}

fn check_preset(name: &str, kind: Option<Kind>, at: (&Doc, usize), r: &mut Report) {
    let ok = match kind {
        Some(Kind::Updater) => PRESET_NAMES.contains(&name),
        Some(Kind::Localiser) => LOCALISER_PRESETS.contains(&name) || name == "auto",
        None => PRESET_NAMES.contains(&name) || LOCALISER_PRESETS.contains(&name),
    };
    let of = match kind {
        Some(Kind::Updater) => "an updater preset",
        Some(Kind::Localiser) => "a localiser preset",
        None => "a preset",
    };
    r.check("preset name", ok, at, || format!("`{name}` is not {of}"));
}

fn word(toks: &[(usize, Tok)], i: isize) -> Option<&str> {
    match toks.get(usize::try_from(i).ok()?) {
        Some((_, Tok::Word(w))) => Some(w),
        _ => None,
    }
}

fn kind_word(w: Option<&str>) -> Option<Kind> {
    match w? {
        "updater" | "updater's" => Some(Kind::Updater),
        "localiser" | "localiser's" => Some(Kind::Localiser),
        _ => None,
    }
}

/// The preset a span next to the word preset(s) names (a name in a list `a`, `b` and `c` too):
/// `Some(kind the words say)`, or `None` when the span is no preset mention.
fn mention(toks: &[(usize, Tok)], i: usize) -> Option<Option<Kind>> {
    let preset = |k: isize| matches!(word(toks, k), Some("preset" | "presets" | "preset's" | "presets'"));
    let in_list = |k: isize| match usize::try_from(k).ok().and_then(|k| toks.get(k)) {
        Some((_, Tok::Span(s))) => is_word(s),
        Some((_, Tok::Word(w))) => w == "and" || w == "or",
        None => false,
    };
    let i = i as isize;
    let (mut before, mut after) = (i - 1, i + 1);
    while in_list(before) {
        before -= 1;
    }
    while in_list(after) {
        after += 1;
    }
    if preset(after) {
        return Some(None);
    }
    if preset(after + 1)
        && let Some(k) = kind_word(word(toks, after))
    {
        return Some(Some(k));
    }
    if preset(before) {
        return Some(kind_word(word(toks, before - 1)));
    }
    matches!(word(toks, i + 1), Some("localiser" | "localisers" | "localiser's")).then_some(Some(Kind::Localiser))
}

fn check_preset_names(doc: &Doc, parsed: &Parsed, r: &mut Report) {
    for (i, (line, t)) in parsed.toks.iter().enumerate() {
        if let Tok::Span(s) = t
            && is_word(s)
            && let Some(kind) = mention(&parsed.toks, i)
        {
            check_preset(s, kind, (doc, *line), r);
        }
    }
    for c in parsed.code.iter().filter(|c| c.fenced && c.text.contains("::preset(")) {
        let kind = if c.text.contains("FilterParams::preset(") { Kind::Localiser } else { Kind::Updater };
        let args = c.text.split("::preset(").nth(1).unwrap().split(')').next().unwrap();
        for name in args.split('"').skip(1).step_by(2) {
            check_preset(name, Some(kind), (doc, c.line), r);
        }
    }
}

fn number(w: Option<&str>) -> Option<usize> {
    let w = w?;
    w.parse().ok().or_else(|| NUMBERS.split_whitespace().position(|n| n == w))
}

/// What a number at `toks[i]` counts, by the header's patterns: (what, the real count).
fn counted(toks: &[(usize, Tok)], i: usize, truth: &Truth) -> Option<(&'static str, usize)> {
    let w = |k: isize| word(toks, i as isize + k);
    let count = |k: Kind| match k {
        Kind::Updater => ("updater presets", PRESET_NAMES.len()),
        Kind::Localiser => ("localiser presets", LOCALISER_PRESETS.len()),
    };
    if let Some(k) = kind_word(w(1)).filter(|_| w(2) == Some("presets")) {
        return Some(count(k));
    }
    // (A possessive `the two presets'` is the word `presets'`: a pair named before, not read.)
    if w(1) == Some("presets") {
        let list = match toks.get(i + 3) {
            Some((_, Tok::Span(s))) if w(2) == Some("of") => s.as_str(),
            _ => "",
        };
        // `N presets (`--localiser` ...)`: the presets of that flag.
        let flag = toks.iter().skip(i + 2).take(2).find_map(|(_, t)| match t {
            Tok::Span(s) if s.starts_with("--localiser") => Some(Kind::Localiser),
            Tok::Span(s) if s.starts_with("--preset") => Some(Kind::Updater),
            _ => None,
        });
        if list == "LOCALISER_PRESETS" || flag == Some(Kind::Localiser) {
            return Some(count(Kind::Localiser));
        }
        if flag == Some(Kind::Updater) {
            return Some(count(Kind::Updater));
        }
        if let Some(k) = kind_word(w(-2)).filter(|_| matches!(w(-1), Some("has" | "with"))) {
            return Some(count(k));
        }
        if matches!(w(-1), Some("the" | "all")) || list == "PRESET_NAMES" {
            return Some(count(Kind::Updater));
        }
    }
    if w(1) == Some("commands") && w(-1) == Some("the") {
        return Some(("commands", truth.cli.top().len()));
    }
    let of_workspace = w(-1) == Some("of") && w(-2) == Some("workspace");
    let crates = w(1) == Some("crates") && (of_workspace || matches!(w(-1), Some("the" | "all")));
    crates.then_some(("crates", truth.packages.len()))
}

/// Whether a heading dates what stands under it (an issue, a commit, a date, `Earlier`).
fn dated(heading: &str) -> bool {
    let h = heading.trim_start_matches('#').trim().to_lowercase();
    let after = |key: &str, ok: fn(char) -> bool| h.match_indices(key).any(|(k, _)| h[k + key.len()..].starts_with(ok));
    h.starts_with("earlier")
        || after("issue ", |c| c.is_ascii_digit())
        || after("commit ", |c| c.is_ascii_hexdigit())
        || after("commits ", |c| c.is_ascii_hexdigit())
        || h.as_bytes().windows(10).any(|w| w[4] == b'-' && w[7] == b'-' && w[..4].iter().all(u8::is_ascii_digit))
}

fn check_counts(doc: &Doc, parsed: &Parsed, truth: &Truth, r: &mut Report) {
    for (i, (line, _)) in parsed.toks.iter().enumerate() {
        let Some(n) = number(word(&parsed.toks, i as isize)) else { continue };
        let Some((what, real)) = counted(&parsed.toks, i, truth) else { continue };
        let text = format!("{} {what}", word(&parsed.toks, i as isize).unwrap());
        if dated(&parsed.heading[line - 1]) {
            r.skip((doc, *line), format!("\"{text}\": a count of its time (dated heading)"));
            continue;
        }
        r.check("count", n == real, (doc, *line), || format!("\"{text}\": there are {real}"));
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Rust names

/// The segments a backtick span names in Rust, if it is a path (`a::b::c`) or a call (`f(…)`,
/// `a::f(…)`: the callee's segments).
fn rust_name(span: &str) -> Option<Vec<&str>> {
    let t = span.trim();
    let (callee, call) = match t.find('(') {
        Some(k) if t.ends_with(')') => (&t[..k], true),
        _ => (t, false),
    };
    let segs: Vec<&str> = callee.split("::").collect();
    let ident = |s: &&str| {
        s.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    ((call || segs.len() > 1) && segs.iter().all(ident)).then_some(segs)
}

fn check_rust_names(doc: &Doc, parsed: &Parsed, truth: &Truth, r: &mut Report) {
    for c in parsed.code.iter().filter(|c| !c.fenced) {
        let Some(segs) = rust_name(&c.text) else { continue };
        if truth.external.contains(segs[0]) {
            r.skip((doc, c.line), format!("`{}`: a name of the crate {}", c.text.trim(), segs[0]));
            continue;
        }
        for seg in segs {
            if let Some((name, why)) = FOREIGN_NAMES.iter().find(|(n, _)| *n == seg) {
                r.used.insert(name.to_string());
                r.skip((doc, c.line), format!("`{seg}`: {why}"));
                continue;
            }
            let ok = truth.idents.contains(seg);
            r.check("rust name", ok, (doc, c.line), || format!("`{seg}` (in `{}`) is in no Rust code", c.text.trim()));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The test

fn check_doc(doc: &Doc, truth: &Truth, r: &mut Report) {
    let parsed = parse(doc);
    check_paths(doc, &parsed, truth, r);
    check_commands(doc, &parsed, truth, r);
    if doc.name == "docs/commands.md" {
        check_command_table(doc, truth, r);
    }
    // The crate map names every crate (the count of crates alone would not say which is missing).
    if doc.name == "docs/ARCHITECTURE.md" {
        for dir in truth.packages.values() {
            let named = doc.lines.iter().any(|l| l.contains(&format!("({dir})")) || l.contains(&format!("`{dir}`")));
            r.check("crate named", named, (doc, 1), || format!("the crate map does not name `{dir}`"));
        }
    }
    check_preset_names(doc, &parsed, r);
    check_counts(doc, &parsed, truth, r);
    check_rust_names(doc, &parsed, truth, r);
}

fn truth() -> &'static Truth {
    static TRUTH: std::sync::OnceLock<Truth> = std::sync::OnceLock::new();
    TRUTH.get_or_init(|| Truth::load(&std::fs::read_to_string(root().join("docs/cli.md")).unwrap()))
}

#[test]
fn every_docs_facts_hold() {
    let truth = truth();
    let mut r = Report::default();
    let docs = docs();
    assert!(docs.len() >= 15, "README.md and docs/*.md: {} docs found", docs.len());
    for doc in &docs {
        check_doc(doc, truth, &mut r);
    }
    let listed = NOT_IN_REPO
        .iter()
        .map(|(p, _)| ("NOT_IN_REPO", p))
        .chain(FOREIGN_NAMES.iter().map(|(n, _)| ("FOREIGN_NAMES", n)));
    for (list, p) in listed.filter(|(_, p)| !r.used.contains(**p)) {
        r.failures.push(format!("{list}: `{p}` is written in no doc any more: drop it"));
    }
    for (f, tool) in FOREIGN_FLAGS {
        let in_file = !tool.contains('/') || std::fs::read_to_string(root().join(tool)).unwrap().contains(f);
        if !r.used.contains(f) || truth.cli.all_flags().contains(f) || !in_file {
            r.failures.push(format!(
                "FOREIGN_FLAGS: `{f}` ({tool}) is written in no doc, or is a flag of mapkeeper, or is not in {tool}"
            ));
        }
    }
    // About half of what today's docs hold (the counts: the four they state).
    let floors = [
        ("path", 200),
        ("command", 100),
        ("flag", 500),
        ("preset name", 130),
        ("count", 3),
        ("cargo target", 20),
        ("rust name", 250),
    ];
    for (kind, floor) in floors {
        let n = r.seen.get(kind).copied().unwrap_or(0);
        if n < floor {
            r.failures.push(format!(
                "only {n} facts of kind {kind:?} seen (floor {floor}): the extractor stopped finding them"
            ));
        }
    }
    println!("facts checked: {:?}\nnot checked ({}):\n{}", r.seen, r.skipped.len(), r.skipped.join("\n"));
    assert!(r.failures.is_empty(), "{} doc facts are wrong:\n{}", r.failures.len(), r.failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// The extractors on small strings

/// The checks of `text` as doc `name`, against the real repository and `docs/cli.md`.
fn failures(name: &str, text: &str) -> (Vec<String>, Report) {
    let mut r = Report::default();
    check_doc(&Doc::new(name, text), truth(), &mut r);
    let mut failures = r.failures.clone();
    failures.sort();
    (failures, r)
}

#[test]
fn a_brace_group_is_expanded_and_each_path_checked() {
    assert_eq!(paths_in("see `crates/a/{b,c}.rs`, and fuzz/x."), ["crates/a/{b,c}.rs", "fuzz/x"]);
    assert_eq!(expand("a/{b,c}/{d,e}.rs"), ["a/b/d.rs", "a/b/e.rs", "a/c/d.rs", "a/c/e.rs"]);
    let (f, r) = failures("docs/x.md", "The tests (`crates/cli/tests/{cli_doc,no_such_test}.rs`).\n");
    assert_eq!(r.seen["path"], 2);
    assert_eq!(f, ["docs/x.md:1: path: `crates/cli/tests/no_such_test.rs` is not in the repository"]);
}

#[test]
fn paths_in_code_blocks_and_crate_relative_paths_are_found() {
    let doc = "Text.\n\n```sh\n  bash .ci/no-such-script 60\n```\n\n`paper/icp.rs` and `tests/additions.rs`, \
               `paper/no_such.rs`; a glob worlds/*.toml and docs/cli.md.\n";
    let (f, r) = failures("docs/x.md", doc);
    assert_eq!(
        f,
        [
            "docs/x.md:4: path: `.ci/no-such-script` is not in the repository",
            "docs/x.md:7: path: `paper/no_such.rs` is not in the repository"
        ]
    );
    assert_eq!(r.seen["path"], 5, "{:?}", r.skipped);
    assert!(r.skipped.iter().any(|s| s.contains("worlds/*.toml")));
}

#[test]
fn commands_and_their_flags_are_the_binarys() {
    let doc = "Run `mapkeeper validate --seeds 3` or `mapkeeper validat`, then `merge --out DIR --trials 2`;\n\
               `mapkeeper experiment table1 --trials 3`, `mapkeeper experiment kidnap --quick`, `experiment lost`.\n\n\
               ```\nmapkeeper recover [--trials 200]\n                  [--no-such-flag]\n```\n";
    let (f, _) = failures("docs/x.md", doc);
    assert_eq!(
        f,
        [
            "docs/x.md:1: command: `mapkeeper validat` is not a command",
            "docs/x.md:1: flag: `--trials` is not a flag of `mapkeeper merge`",
            "docs/x.md:2: command: `mapkeeper experiment kidnap` is not a command",
            "docs/x.md:2: command: `mapkeeper experiment lost` is not a command",
            "docs/x.md:6: flag: `--no-such-flag` is not a flag of `mapkeeper recover`"
        ]
    );
}

#[test]
fn a_foreign_flag_is_allowed_only_as_its_tools() {
    let doc = "`cargo test --workspace --release --locked`, `cargo bench -p mapkeeper-grid --bench traversal`, \
               `cargo bench -p mapkeeper-grid --bench no_such`; `--frobnicate`; `mapkeeper run --release`.\n";
    let (f, r) = failures("docs/x.md", doc);
    assert_eq!(
        f,
        [
            "docs/x.md:1: cargo target: `--bench no_such`: no such target in crates/grid/benches/",
            "docs/x.md:1: flag: `--frobnicate` is not a flag of mapkeeper",
            "docs/x.md:1: flag: `--release` is not a flag of `mapkeeper run`"
        ]
    );
    assert!(r.skipped.iter().any(|s| s.contains("`--locked`: cargo's")));
}

#[test]
fn preset_names_are_the_codes() {
    let doc = "The `paper` preset, presets `authors`, `no-such` and `log-odds`, the `amcl` localiser, \
               the `paper` localiser, `validate --presets paper,nope --localiser amcl|auto`.\n\n\
               ```rust\nUpdaterParams::preset(\"authors\" | \"nada\")\n```\n";
    let (f, r) = failures("docs/x.md", doc);
    assert_eq!(
        f,
        [
            "docs/x.md:1: preset name: `no-such` is not a preset",
            "docs/x.md:1: preset name: `nope` is not an updater preset",
            "docs/x.md:1: preset name: `paper` is not a localiser preset",
            "docs/x.md:4: preset name: `nada` is not an updater preset"
        ]
    );
    assert_eq!(r.seen["preset name"], 12);
}

#[test]
fn a_wrong_count_is_caught() {
    // Written from today's counts, so that adding a preset or a command does not break it.
    let (u, l) = (PRESET_NAMES.len(), LOCALISER_PRESETS.len());
    let (c, k) = (truth().cli.top().len(), truth().packages.len());
    let doc = format!(
        "The localiser has {l} presets; {u} updater presets, all {u} presets, the {} presets' worlds,\n\
         the {} commands, a Cargo workspace of {k} crates. Six presets run it. {} presets\n\
         (`--localiser`).\n\n## Earlier: issue 11\n\nAll {} updater presets.\n",
        u + 1,
        c - 1,
        l + 1,
        u + 1
    );
    let (f, r) = failures("docs/x.md", &doc);
    assert_eq!(
        f,
        [
            format!("docs/x.md:2: count: \"{} commands\": there are {c}", c - 1),
            format!("docs/x.md:2: count: \"{} localiser presets\": there are {l}", l + 1),
        ]
    );
    assert_eq!(r.seen["count"], 6);
    assert!(r.skipped.iter().any(|s| s.contains(&format!("\"{} updater presets\": a count of its time", u + 1))));
    // Number words count too.
    let wrong = NUMBERS.split_whitespace().nth(u + 1).unwrap();
    let (f, _) = failures("docs/x.md", &format!("There are {wrong} updater presets.\n"));
    assert_eq!(f, [format!("docs/x.md:1: count: \"{wrong} updater presets\": there are {u}")]);
}

#[test]
fn rust_names_are_the_codes() {
    assert_eq!(rust_name("harness::run(source, session)"), Some(vec!["harness", "run"]));
    assert_eq!(rust_name("change_state_bytes()"), Some(vec!["change_state_bytes"]));
    assert_eq!(rust_name("paper"), None);
    let doc =
        "`mapkeeper_updater::MapUpdater::no_such_fn`, `harness::run`, `std::fs::nothing`, `cast_rays_wrongly()`.\n";
    let (f, r) = failures("docs/x.md", doc);
    assert_eq!(
        f,
        [
            "docs/x.md:1: rust name: `cast_rays_wrongly` (in `cast_rays_wrongly()`) is in no Rust code",
            "docs/x.md:1: rust name: `no_such_fn` (in `mapkeeper_updater::MapUpdater::no_such_fn`) is in no Rust code"
        ]
    );
    assert_eq!(r.seen["rust name"], 6);
}
