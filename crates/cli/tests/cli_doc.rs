//! `docs/cli.md` is the binary's own help, every command and subcommand, held by this test: it
//! renders the reference from `mapkeeper --help` and each `mapkeeper <cmd> [<sub>] --help` and
//! fails when the file differs (the docs drifted from the code). To rewrite the file after a
//! change of the command line:
//!
//! ```sh
//! MAPKEEPER_BLESS_DOCS=1 cargo test --release -p mapkeeper --test cli_doc
//! ```
#![allow(clippy::unwrap_used)]

mod common;

use common::{help_commands as commands, mapkeeper};
use std::path::PathBuf;

fn help(args: &[&str]) -> String {
    let mut all: Vec<&str> = args.to_vec();
    all.push("--help");
    let out = mapkeeper(&all);
    assert!(out.status.success(), "mapkeeper {all:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn section(md: &mut String, args: &[&str], text: &str) {
    let title = if args.is_empty() { "mapkeeper".to_string() } else { format!("mapkeeper {}", args.join(" ")) };
    md.push_str(&format!("\n## `{title}`\n\n```text\n{}\n```\n", text.trim_end()));
}

/// The reference: the top-level help, then each command's, each followed by its subcommands'.
fn render() -> String {
    let mut md = String::from(
        "# Command-line reference\n\n\
         Generated from the binary's own `--help` by `crates/cli/tests/cli_doc.rs`, which fails when\n\
         this file and the code differ; rewrite it with\n\
         `MAPKEEPER_BLESS_DOCS=1 cargo test --release -p mapkeeper --test cli_doc`.\n\
         What the commands are for, with examples: `docs/commands.md`.\n",
    );
    let top = help(&[]);
    section(&mut md, &[], &top);
    for cmd in commands(&top) {
        let text = help(&[&cmd]);
        section(&mut md, &[&cmd], &text);
        for sub in commands(&text) {
            section(&mut md, &[&cmd, &sub], &help(&[&cmd, &sub]));
        }
    }
    md
}

#[test]
fn docs_cli_md_is_the_binarys_own_help() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/cli.md");
    let want = render();
    // Every command of the top-level help has its section, and the experiments' subcommands theirs.
    assert!(want.contains("## `mapkeeper validate`") && want.contains("## `mapkeeper experiment kidnap-robot`"));
    if std::env::var_os("MAPKEEPER_BLESS_DOCS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    if have != want {
        let line = have
            .lines()
            .zip(want.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(have.lines().count().min(want.lines().count()));
        panic!(
            "docs/cli.md differs from the binary's help from line {} on (file: {:?}, help: {:?}); rewrite it with \
             MAPKEEPER_BLESS_DOCS=1 cargo test --release -p mapkeeper --test cli_doc",
            line + 1,
            have.lines().nth(line),
            want.lines().nth(line)
        );
    }
}
