//! The `console` examples of the README and of `docs/*.md` are run as written (issue 32):
//! each block in a scratch folder of its own holding the sample `data/`, its commands in
//! order, each one's output (stdout, then stderr) and exit code compared with what the
//! page shows. So a default, a message or an exit code cannot change without a page
//! failing here.
//!
//! The format, in a fenced block tagged `console`:
//! - `$ activeskin ARGS` runs the binary (quotes as a shell reads them; a line ending in
//!   `\` goes on on the next);
//! - the lines after it are its output; `[..]` in a line stands for any text there (what
//!   depends on the machine: times, memory), and a line `...` for any lines;
//! - `? N` ends an output with exit code N (0 when not given).
//!
//! A block tagged `console slow` (a long run, a cache) is left out of the suite and run by
//! `make bench` (`cargo test --release --test readme -- --ignored`).
#![cfg(feature = "cli")]

mod common;

use std::path::Path;
use std::process::Command;

/// One command of a block and what its page shows of it.
struct Example {
    /// `page:line`, for the failure's message.
    at: String,
    args: Vec<String>,
    expected: Vec<String>,
    code: i32,
}

/// A page's `console` blocks (`console slow` ones when `slow`), each a list of examples.
fn blocks(page: &str, text: &str, slow: bool) -> Vec<Vec<Example>> {
    let tag = match slow {
        false => "```console",
        true => "```console slow",
    };
    let mut blocks = Vec::new();
    let mut lines = text.lines().enumerate().peekable();
    while let Some((_, line)) = lines.next() {
        if line.trim() != tag {
            continue;
        }
        // A block in a list item is indented as the item's text.
        let indent = line.len() - line.trim_start().len();
        let mut examples: Vec<Example> = Vec::new();
        while let Some((n, line)) = lines.next() {
            let line = line
                .get(indent..)
                .filter(|_| line.len() >= indent)
                .unwrap_or(line.trim_start());
            if line.starts_with("```") {
                break;
            }
            if let Some(command) = line.strip_prefix("$ ") {
                let mut command = command.to_string();
                while command.ends_with('\\') {
                    command.pop();
                    let (_, next) = lines.next().expect("a continued command");
                    command.push_str(next.trim_start());
                    command.insert(command.len() - next.trim_start().len(), ' ');
                }
                let words = split(&command);
                assert_eq!(
                    words.first().map(String::as_str),
                    Some("activeskin"),
                    "{page}:{}: only activeskin commands run here",
                    n + 1
                );
                examples.push(Example {
                    at: format!("{page}:{}", n + 1),
                    args: words[1..].to_vec(),
                    expected: Vec::new(),
                    code: 0,
                });
            } else if let Some(code) = line.strip_prefix("? ") {
                examples
                    .last_mut()
                    .expect("an exit code after a command")
                    .code = code.trim().parse().expect("an exit code");
            } else {
                let last = examples
                    .last_mut()
                    .unwrap_or_else(|| panic!("{page}:{}: output before any command", n + 1));
                last.expected.push(line.to_string());
            }
        }
        blocks.push(examples);
    }
    blocks
}

/// A command line split into words as a POSIX shell would: single quotes keep everything,
/// double quotes keep all but `\"`, unquoted spaces separate.
fn split(command: &str) -> Vec<String> {
    let (mut words, mut word, mut started) = (Vec::new(), String::new(), false);
    let mut chars = command.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                started = true;
                for q in chars.by_ref() {
                    if q == '\'' {
                        break;
                    }
                    word.push(q);
                }
            }
            '"' => {
                started = true;
                while let Some(q) = chars.next() {
                    match q {
                        '"' => break,
                        '\\' if chars.peek() == Some(&'"') => word.push(chars.next().unwrap()),
                        _ => word.push(q),
                    }
                }
            }
            ' ' | '\t' => {
                if started {
                    words.push(std::mem::take(&mut word));
                    started = false;
                }
            }
            _ => {
                started = true;
                word.push(c);
            }
        }
    }
    if started {
        words.push(word);
    }
    words
}

/// Whether `line` is `pattern`, `[..]` in the pattern standing for any text.
fn line_matches(pattern: &str, line: &str) -> bool {
    let mut parts = pattern.split("[..]");
    let first = parts.next().unwrap_or("");
    let Some(mut rest) = line.strip_prefix(first) else {
        return false;
    };
    let parts: Vec<&str> = parts.collect();
    for (i, part) in parts.iter().enumerate() {
        if i + 1 == parts.len() {
            return rest.ends_with(part);
        }
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    rest.is_empty()
}

/// Whether `lines` are `patterns`, a pattern line `...` standing for any lines.
fn lines_match(patterns: &[String], lines: &[&str]) -> bool {
    match patterns.split_first() {
        None => lines.is_empty(),
        Some((p, rest)) if p == "..." => {
            (0..=lines.len()).any(|skip| lines_match(rest, &lines[skip..]))
        }
        Some((p, rest)) => {
            !lines.is_empty() && line_matches(p, lines[0]) && lines_match(rest, &lines[1..])
        }
    }
}

/// Runs `blocks`, each in a scratch folder holding `data/`; the failures, described.
fn run(blocks: &[Vec<Example>]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut failures = Vec::new();
    let mut ran = 0;
    for block in blocks {
        let dir = common::scratch();
        std::os::unix::fs::symlink(root.join("data"), dir.path().join("data")).unwrap();
        for example in block {
            let out = Command::new(env!("CARGO_BIN_EXE_activeskin"))
                .args(&example.args)
                .current_dir(dir.path())
                // The widths and colours clap would take from a terminal.
                .env("COLUMNS", "100")
                .env_remove("TERM")
                .output()
                .unwrap();
            ran += 1;
            let printed = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            let lines: Vec<&str> = printed.lines().collect();
            let code = out.status.code().unwrap_or(-1);
            // A page's blank line after the output is not output.
            let mut expected = example.expected.clone();
            while expected.last().is_some_and(|l| l.is_empty()) {
                expected.pop();
            }
            if code != example.code || !lines_match(&expected, &lines) {
                failures.push(format!(
                    "{}: activeskin {}\n  the page shows (exit {}):\n    {}\n  printed (exit {code}):\n    {}",
                    example.at,
                    example.args.join(" "),
                    example.code,
                    expected.join("\n    "),
                    lines.join("\n    ")
                ));
            }
        }
    }
    println!("{ran} examples run");
    failures
}

/// The blocks of the README and of every page in `docs/`.
fn all_blocks(slow: bool) -> Vec<Vec<Example>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages = vec!["README.md".to_string()];
    let mut docs: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/{name}"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
        .iter()
        .flat_map(|page| {
            let text = std::fs::read_to_string(root.join(page)).unwrap();
            blocks(page, &text, slow)
        })
        .collect()
}

#[test]
fn the_pages_examples_print_what_they_show() {
    let blocks = all_blocks(false);
    assert!(blocks.len() >= 8, "{} console blocks", blocks.len());
    let failures = run(&blocks);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The long examples (`console slow`): `make bench` runs them.
#[test]
#[ignore = "long runs: make bench"]
fn the_pages_long_examples_print_what_they_show() {
    let blocks = all_blocks(true);
    assert!(!blocks.is_empty(), "no console slow block");
    let failures = run(&blocks);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_harness_reads_shell_words_and_wildcards() {
    assert_eq!(
        split(r#"activeskin skin --target 'a b.####.vdb' --x "c \"d\"" e"#),
        [
            "activeskin",
            "skin",
            "--target",
            "a b.####.vdb",
            "--x",
            "c \"d\"",
            "e"
        ]
    );
    assert!(line_matches(
        "took [..] ms, [..] MB",
        "took 12.5 ms, 300 MB"
    ));
    assert!(!line_matches("took [..] ms", "took 12.5 s"));
    assert!(!line_matches("exact", "exactly"));
    let patterns: Vec<String> = ["a", "...", "z"].map(String::from).to_vec();
    assert!(lines_match(&patterns, &["a", "b", "c", "z"]));
    assert!(lines_match(&patterns, &["a", "z"]));
    assert!(!lines_match(&patterns, &["a", "b"]));
}

/// The README stays a guide (issue 50: at most ~250 lines, the details in `docs/`), and
/// every relative link of the README and the pages points at a file that is there.
#[test]
fn the_readme_is_short_and_every_link_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(
        lines <= 250,
        "README.md is {lines} lines: move details to docs/"
    );
    let mut pages = vec![root.join("README.md"), root.join("CHANGELOG.md")];
    for entry in std::fs::read_dir(root.join("docs")).unwrap() {
        pages.push(entry.unwrap().path());
    }
    let mut broken = Vec::new();
    let mut links = 0;
    for page in pages
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
    {
        let text = std::fs::read_to_string(page).unwrap();
        for (at, _) in text.match_indices("](") {
            let rest = &text[at + 2..];
            let Some(end) = rest.find(')') else { continue };
            let target = rest[..end].split('#').next().unwrap();
            if target.is_empty() || target.contains("://") {
                continue;
            }
            links += 1;
            if !page.parent().unwrap().join(target).exists() {
                broken.push(format!("{}: {target}", page.display()));
            }
        }
    }
    assert!(links >= 20, "{links} links");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}
