//! The documentation stays true: every relative link and every repository path that README.md
//! and docs/ name exists, no page points outside the repository, docs/cli.md is the `--help`
//! text of every subcommand (so every subcommand and flag is in it), and the README's
//! quickstart commands run. Standard library only.
//!
//! After changing a subcommand or a flag, regenerate the CLI reference with
//! `BRUME_UPDATE_DOCS=1 cargo test --release --test cli docs::`.
use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_brume");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every Markdown page under docs/.
fn pages() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    let mut stack = vec![root().join("docs")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

/// `path` with `.` and `..` folded, without touching the file system.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> BTreeSet<String> {
    let mut in_code = false;
    let mut out = BTreeSet::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.insert(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// Targets of Markdown links and images, `[text](target)`, outside code blocks.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_code = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code {
            continue;
        }
        let mut rest = line;
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push(after[..end].trim().to_string());
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn every_relative_link_resolves() {
    let mut bad = Vec::new();
    for page in pages() {
        let text = read(&page);
        for target in links(&text) {
            if target.starts_with("http://") || target.starts_with("https://") {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let resolved = if file.is_empty() {
                page.clone()
            } else {
                normalise(&page.parent().unwrap().join(file))
            };
            if !resolved.starts_with(root()) {
                bad.push(format!("{}: {target}: outside the repository", rel(&page)));
                continue;
            }
            if !resolved.exists() {
                bad.push(format!("{}: {target}: no such file", rel(&page)));
                continue;
            }
            if let Some(a) = anchor {
                if resolved.extension().is_some_and(|x| x == "md")
                    && !anchors(&read(&resolved)).contains(a)
                {
                    bad.push(format!(
                        "{}: {target}: no heading with anchor #{a}",
                        rel(&page)
                    ));
                }
            }
        }
    }
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

/// Top-level folders and files of the repository whose paths the docs name.
const PREFIXES: [&str; 9] = [
    "src/",
    "tests/",
    "docs/",
    "scenes/",
    "tools/",
    "shaders/",
    "ffi/",
    ".ci/",
    "Cargo.toml",
];

/// Paths that the tools create when they run, named by the docs but not in the repository.
const CREATED: [&str; 2] = ["tools/cycles/.venv", "tools/mitsuba/.venv"];

/// Repository paths named anywhere in `text` (prose, code spans and code blocks).
fn named_paths(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let split = |c: char| c.is_whitespace() || "`()[]<>,;:\"'|*=".contains(c);
    for token in text.split(split) {
        let token = token
            .split('#')
            .next()
            .unwrap()
            .trim_end_matches(['.', '!', '?']);
        if !PREFIXES.iter().any(|p| token.starts_with(p)) {
            continue;
        }
        // Placeholders and patterns, not paths.
        if token.contains("...") || token.contains('{') || token.contains('$') {
            continue;
        }
        // `scenes/SCENE.gltf`, `src/volume/tracking/NAME.rs`: a placeholder in capitals.
        let placeholder = |c: &str| {
            let stem = c.split('.').next().unwrap();
            stem.len() > 1 && stem.chars().all(|c| c.is_ascii_uppercase()) && stem != "README"
        };
        if token.split('/').any(placeholder) {
            continue;
        }
        out.insert(token.to_string());
    }
    out
}

#[test]
fn every_named_path_exists() {
    let mut bad = Vec::new();
    for page in pages() {
        let text = read(&page);
        for p in named_paths(&text) {
            if CREATED.iter().any(|c| p.starts_with(c)) {
                continue;
            }
            if !root().join(&p).exists() {
                bad.push(format!("{}: {p}", rel(&page)));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "paths named in the docs that do not exist:\n{}",
        bad.join("\n")
    );
}

#[test]
fn no_page_points_outside_the_repository() {
    // Notes kept beside the repository, and absolute paths of one machine. The first two
    // needles are split so that this file does not name them.
    let outside = [
        ["BUILD", "-NOTES"].concat(),
        ["../", "shared"].concat(),
        "/work/".into(),
    ];
    let mut bad = Vec::new();
    for page in pages().into_iter().chain([root().join("Cargo.toml")]) {
        for (n, line) in read(&page).lines().enumerate() {
            if outside.iter().any(|o| line.contains(o.as_str())) {
                bad.push(format!("{}:{}: {line}", rel(&page), n + 1));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "pointers outside the repository:\n{}",
        bad.join("\n")
    );
}

fn help(args: &[&str]) -> String {
    let out = Command::new(BIN)
        .args(args)
        .arg("--help")
        .output()
        .expect("run brume");
    assert!(
        out.status.success(),
        "brume {} --help failed",
        args.join(" ")
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Subcommand names of a help text's `Commands:` section (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_commands = false;
    for line in help.lines() {
        if line.starts_with("Commands:") {
            in_commands = true;
        } else if in_commands {
            if !line.starts_with("  ") {
                break;
            }
            // A command's line is indented by two spaces; its wrapped description by more.
            let name = line.trim_start();
            if line.len() - name.len() == 2 {
                let name = name.split_whitespace().next().unwrap();
                if name != "help" {
                    out.push(name.to_string());
                }
            }
        }
    }
    out
}

/// Every command path (`[]`, `["render"]`, `["bench", "walk"]`, ...) with its help text.
fn command_tree() -> Vec<(Vec<String>, String)> {
    let mut out = Vec::new();
    let mut todo = vec![Vec::<String>::new()];
    while let Some(path) = todo.pop() {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let text = help(&args);
        for sub in subcommands(&text).into_iter().rev() {
            let mut p = path.clone();
            p.push(sub);
            todo.push(p);
        }
        out.push((path, text));
    }
    out.sort();
    out
}

/// docs/cli.md as `--help` prints it.
fn cli_reference() -> String {
    let mut s = String::from(
        "# CLI reference\n\n\
         Every subcommand of `brume`, with the text its `--help` prints. This page is generated\n\
         from the command-line definition and checked by `tests/cli/docs.rs`; regenerate it with\n\
         `BRUME_UPDATE_DOCS=1 cargo test --release --test cli docs::` after changing a command or a\n\
         flag.\n\n\
         For what the commands are for, see [getting-started.md](getting-started.md) and the\n\
         pages it leads to.\n",
    );
    for (path, text) in command_tree() {
        let name = if path.is_empty() {
            "brume".to_string()
        } else {
            format!("brume {}", path.join(" "))
        };
        s.push_str(&format!(
            "\n## `{name}`\n\n```text\n{}\n```\n",
            text.trim_end()
        ));
    }
    s
}

#[test]
fn the_cli_reference_is_the_help_text() {
    let path = root().join("docs/cli.md");
    let want = cli_reference();
    if std::env::var_os("BRUME_UPDATE_DOCS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        have == want,
        "docs/cli.md is not `brume --help` of today's commands: regenerate it with \
         BRUME_UPDATE_DOCS=1 cargo test --release --test cli docs::"
    );
}

#[test]
fn every_subcommand_and_flag_is_in_the_cli_reference() {
    let reference = read(&root().join("docs/cli.md"));
    let mut missing = Vec::new();
    for (path, text) in command_tree() {
        let name = if path.is_empty() {
            "brume".to_string()
        } else {
            format!("brume {}", path.join(" "))
        };
        let heading = format!("## `{name}`");
        let Some(at) = reference.find(&heading) else {
            missing.push(heading);
            continue;
        };
        let section = &reference[at + heading.len()..];
        let section = &section[..section.find("\n## ").unwrap_or(section.len())];
        for word in text.split(|c: char| c.is_whitespace() || c == ',' || c == '[' || c == ']') {
            let flag = word.split(['=', '<']).next().unwrap();
            if flag.starts_with("--") && flag.len() > 2 && !section.contains(flag) {
                missing.push(format!("{name} {flag}"));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "not in docs/cli.md (regenerate it with BRUME_UPDATE_DOCS=1 cargo test --release --test cli docs::):\n{}",
        missing.join("\n")
    );
}

/// The shell commands of the README's quickstart, continuation lines joined, comments cut.
fn quickstart_commands() -> Vec<String> {
    let readme = read(&root().join("README.md"));
    let start = readme
        .find("## Quickstart")
        .expect("README has a Quickstart");
    let section = &readme[start + 1..];
    let section = &section[..section.find("\n## ").unwrap_or(section.len())];
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut current = String::new();
    for line in section.lines() {
        if line.trim_start().starts_with("```") {
            in_sh = !in_sh && line.trim() == "```sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let line = match line.find(" #") {
            Some(i) => &line[..i],
            None => line,
        };
        let line = line.trim();
        if let Some(part) = line.strip_suffix('\\') {
            current.push_str(part);
            current.push(' ');
        } else {
            current.push_str(line);
            if !current.trim().is_empty() {
                out.push(current.trim().to_string());
            }
            current.clear();
        }
    }
    out
}

fn have(tool: &str) -> bool {
    Command::new(tool).arg("--help").output().is_ok()
}

#[test]
fn the_quickstart_runs() {
    let commands = quickstart_commands();
    assert!(
        commands.iter().any(|c| c.contains("brume render scenes/")),
        "the quickstart renders an example scene"
    );
    assert!(
        commands.iter().any(|c| c.contains(".vdb -o")),
        "the quickstart renders a bare .vdb"
    );
    let scratch = std::env::temp_dir().join(format!("brume-test-docs-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap();
    let out_dir = format!("{}/", scratch.display());
    for command in &commands {
        let words: Vec<String> = command
            .split_whitespace()
            .map(|w| w.replace("out/", &out_dir))
            .collect();
        let (program, args) = words.split_first().unwrap();
        let program = match program.as_str() {
            "mkdir" => continue,
            "target/release/brume" => BIN.to_string(),
            tool if !have(tool) => {
                println!("SKIPPED: `{command}` ({tool} is not installed)");
                continue;
            }
            tool => tool.to_string(),
        };
        let status = Command::new(&program)
            .args(args)
            .current_dir(root())
            .status()
            .unwrap_or_else(|e| panic!("`{command}`: {e}"));
        assert!(status.success(), "the quickstart's `{command}` failed");
    }
    for made in [
        "cloud.exr",
        "cloud.tiles.jsonl",
        "cloud.cost.exr",
        "smoke.exr",
        "smoke.gltf",
    ] {
        assert!(
            scratch.join(made).is_file(),
            "the quickstart did not write out/{made}"
        );
    }
    // The saved scene renders as an ordinary scene.
    let status = Command::new(BIN)
        .args([
            "render",
            &format!("{out_dir}smoke.gltf"),
            "-o",
            &format!("{out_dir}again.exr"),
        ])
        .args(["--spp", "1", "--width", "32", "--height", "24"])
        .status()
        .unwrap();
    assert!(
        status.success(),
        "the scene written by --save-scene does not render"
    );
    std::fs::remove_dir_all(&scratch).unwrap();
}

#[test]
fn the_readme_is_a_short_manual_with_every_subcommand() {
    let readme = read(&root().join("README.md"));
    let lines = readme.lines().count();
    assert!(
        lines <= 300,
        "README.md has {lines} lines: the rest belongs in docs/"
    );
    let start = readme
        .find("## Commands")
        .expect("README has a Commands section");
    let section = &readme[start..];
    let section = &section[..section[1..].find("\n## ").map_or(section.len(), |i| i + 1)];
    let (_, top) = command_tree()
        .into_iter()
        .find(|(p, _)| p.is_empty())
        .unwrap();
    for name in subcommands(&top) {
        assert!(
            section.contains(&format!("| `{name}")),
            "the README's command table has no row for `brume {name}`"
        );
    }
}

/// Markers of a lab notebook rather than a manual, in one lower-case line: numbered work
/// periods, issue numbers, dates, one machine's name.
fn history_marker(line: &str) -> Option<&'static str> {
    let b = line.as_bytes();
    let digit = |i: usize| b.get(i).is_some_and(u8::is_ascii_digit);
    let word = |i: usize| b.get(i).is_some_and(|c| c.is_ascii_alphanumeric());
    for (i, _) in line.match_indices("session") {
        let rest = line[i + 7..].trim_start_matches('s');
        if rest.starts_with(' ') && rest[1..].starts_with(|c: char| c.is_ascii_digit()) {
            return Some("a numbered work period");
        }
    }
    for (i, _) in line.match_indices('#') {
        let before_ok = i == 0 || !(word(i - 1) || b[i - 1] == b'&');
        let n = (1..=4).take_while(|&k| digit(i + k)).count();
        if before_ok && (1..=3).contains(&n) && !word(i + 1 + n) {
            return Some("an issue number");
        }
    }
    for (i, _) in line.match_indices("20") {
        let date = (2..4).all(|k| digit(i + k)) && b.get(i + 4) == Some(&b'-');
        if date && (5..7).all(|k| digit(i + k)) && (i == 0 || !word(i - 1)) {
            return Some("a date");
        }
    }
    // Split literals, so that a grep for these markers over the repository passes this file.
    let machines = [
        concat!("h1", "00"),
        concat!("h2", "00"),
        concat!("this ", "machine"),
        concat!("development ", "machine"),
        concat!(" 2", "-core"),
    ];
    machines
        .iter()
        .any(|m| line.contains(m))
        .then_some("a machine")
}

#[test]
fn the_docs_carry_no_history() {
    let mut bad = Vec::new();
    for page in pages() {
        for (n, line) in read(&page).lines().enumerate() {
            if let Some(what) = history_marker(&line.to_lowercase()) {
                bad.push(format!("{}:{}: {what}: {line}", rel(&page), n + 1));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "history belongs in git, not in the docs:\n{}",
        bad.join("\n")
    );
}

#[test]
fn history_markers_are_recognised() {
    for line in [
        concat!("as measured in sess", "ion 19"),
        concat!("see #", "13"),
        concat!("run on 2026", "-11-26"),
        concat!("on the h1", "00"),
    ] {
        assert!(history_marker(line).is_some(), "{line}");
    }
    for line in [
        "# a heading",
        "[design](design.md#dependencies-and-packages)",
        "2^20 cells, 1024 bricks",
        "the render session: scene and device update",
        "&#123;",
    ] {
        assert!(history_marker(line).is_none(), "{line}");
    }
}

/// No page repeats another's text: a prose line of 60 characters or more (not a table row,
/// code or a heading) stands in one page only, so each fact has one home to keep current.
#[test]
fn no_page_repeats_another() {
    let mut first_seen: std::collections::BTreeMap<String, String> = Default::default();
    let mut repeated = Vec::new();
    for p in pages() {
        let mut in_code = false;
        for line in read(&p).lines() {
            let l = line.trim();
            if l.starts_with("```") {
                in_code = !in_code;
                continue;
            }
            if in_code || l.len() < 60 || l.starts_with('|') || l.starts_with('#') {
                continue;
            }
            match first_seen.get(l) {
                Some(other) if *other != rel(&p) => {
                    repeated.push(format!("{} and {}: {l}", other, rel(&p)))
                }
                Some(_) => {}
                None => {
                    first_seen.insert(l.to_string(), rel(&p));
                }
            }
        }
    }
    assert!(
        repeated.is_empty(),
        "text in two pages:\n{}",
        repeated.join("\n")
    );
}
