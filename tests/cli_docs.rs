//! docs/cli.md against `--help`: every flag the reference lists (in its synopses and flag
//! tables) exists in the subcommand's `--help`, and every flag `--help` shows is documented in
//! the subcommand's section.

use std::collections::BTreeSet;
use std::process::Command;

const SUBCOMMANDS: [&str; 6] = ["mesh", "stats", "gallery", "image", "remesh", "surface"];

/// The `--long` flags in `text` (words starting with two dashes and a letter).
fn flags_in(text: &str) -> BTreeSet<String> {
    let b = text.as_bytes();
    let mut out = BTreeSet::new();
    let mut i = 0;
    while i + 2 < b.len() {
        let starts = b[i] == b'-' && b[i + 1] == b'-' && b[i + 2].is_ascii_lowercase();
        let after_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'-');
        if starts && !after_word {
            let mut j = i + 2;
            while j < b.len() && (b[j].is_ascii_lowercase() || b[j].is_ascii_digit() || b[j] == b'-') {
                j += 1;
            }
            out.insert(text[i..j].trim_end_matches('-').to_string());
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// The flags `trussmesh SUB --help` lists (the first words of its option lines).
fn help_flags(sub: &str) -> BTreeSet<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh")).args([sub, "--help"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let mut flags = BTreeSet::new();
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('-') {
            let head = t.split("  ").next().unwrap_or("");
            flags.extend(flags_in(head));
        }
    }
    flags.remove("--help");
    flags
}

/// The section "## `trussmesh SUB`" of docs/cli.md (to the next level-2 heading), and the
/// flags the reference lists for SUB: its synopsis lines ("trussmesh SUB ...", at the top and
/// in the section) and its flag tables' first column.
fn doc_flags(doc: &str, sub: &str) -> (String, BTreeSet<String>) {
    let head = format!("## `trussmesh {sub}`");
    let start = doc.find(&head).unwrap_or_else(|| panic!("docs/cli.md has no section {head}"));
    let rest = &doc[start + head.len()..];
    let section = &rest[..rest.find("\n## ").unwrap_or(rest.len())];
    let synopsis = format!("trussmesh {sub} ");
    let mut listed = BTreeSet::new();
    for line in doc.lines().filter(|l| l.starts_with(&synopsis)) {
        listed.extend(flags_in(line));
    }
    // Flags of every subcommand (`global` in clap) are listed once, in their own section.
    let global = "## Flags of every subcommand";
    let start = doc.find(global).unwrap_or_else(|| panic!("docs/cli.md has no section {global}"));
    let rest = &doc[start..];
    for line in rest[..rest[1..].find("\n## ").map_or(rest.len(), |e| e + 1)].lines() {
        if let Some(row) = line.strip_prefix("| `-") {
            listed.extend(flags_in(&format!("`-{}", row.split(" |").next().unwrap_or(""))));
        }
    }
    for line in section.lines() {
        if line.starts_with(&synopsis) {
            listed.extend(flags_in(line));
        } else if let Some(row) = line.strip_prefix("| `-") {
            listed.extend(flags_in(&format!("`-{}", row.split(" |").next().unwrap_or(""))));
        }
    }
    (section.to_string(), listed)
}

#[test]
fn docs_cli_md_and_help_list_the_same_flags() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/cli.md")).unwrap();
    let mut problems = Vec::new();
    for sub in SUBCOMMANDS {
        let help = help_flags(sub);
        let (section, listed) = doc_flags(&doc, sub);
        let mentioned = flags_in(&section);
        println!("{sub:8} --help: {} flags; docs list {}: {:?}", help.len(), listed.len(), help);
        for f in listed.difference(&help) {
            problems.push(format!("docs/cli.md lists {f} for `trussmesh {sub}`, which its --help does not have"));
        }
        for f in help.iter().filter(|f| !mentioned.contains(*f) && !listed.contains(*f)) {
            problems.push(format!("`trussmesh {sub} --help` has {f}, which docs/cli.md does not document"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn help_shows_the_defaults_and_required_flags() {
    let help = |sub: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_trussmesh")).args([sub, "--help"]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let mesh = help("mesh");
    for want in ["[default: 2]", "1000 in 2-D, 300 in 3-D", "[default: 0]"] {
        assert!(mesh.contains(want), "mesh --help does not say {want:?}:\n{mesh}");
    }
    // -o is declared required: clap refuses a run without it before any work.
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(["mesh", "--domain", "x", "--h0", "0.1", "--bbox", "-1,-1,1,1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(err.contains("required") && err.contains("--output"), "{err}");
}
