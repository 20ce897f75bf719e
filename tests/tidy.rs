//! The documents tell the truth about the tree: every repository path they name exists,
//! and every crate has its section in ARCHITECTURE.md's code map.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Where the repository is.
fn root() -> &'static Path {
    Path::new(repo_root!())
}

/// Every file and folder of the repository, relative to its root, with `/` separators.
fn tree() -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let mut pending = vec![PathBuf::new()];
    while let Some(relative) = pending.pop() {
        let entries =
            std::fs::read_dir(root().join(&relative)).unwrap_or_else(|e| panic!("{relative:?}: {e}"));
        for entry in entries {
            let entry = entry.expect("a directory entry");
            let name = entry.file_name().to_string_lossy().into_owned();
            if crate::util::MADE_FOLDERS.contains(&name.as_str()) {
                continue;
            }
            let path = relative.join(&name);
            found.insert(path.to_string_lossy().replace('\\', "/"));
            if entry.file_type().expect("a file type").is_dir() {
                pending.push(path);
            }
        }
    }
    found
}

/// The documents whose paths are checked.
fn documents() -> Vec<String> {
    let mut docs: Vec<String> = [
        "README.md",
        "ARCHITECTURE.md",
        "CHANGELOG.md",
        "python/README.md",
        "maps/README.md",
        "fuzz/README.md",
    ]
    .map(str::to_string)
    .to_vec();
    for folder in ["docs", "protocol"] {
        for entry in std::fs::read_dir(root().join(folder)).expect("a docs folder") {
            let name = entry.expect("an entry").file_name().to_string_lossy().into_owned();
            if name.ends_with(".md") {
                docs.push(format!("{folder}/{name}"));
            }
        }
    }
    docs
}

/// Each checked document with its text.
fn document_texts() -> Vec<(String, String)> {
    documents()
        .into_iter()
        .map(|document| {
            let text =
                std::fs::read_to_string(root().join(&document)).unwrap_or_else(|e| panic!("{document}: {e}"));
            (document, text)
        })
        .collect()
}

/// What a code span names, if it is a path: path characters only, ending in a file
/// extension or `/`, and no placeholder such as `DIR` or `OUT` in it.
fn named_path(span: &str) -> Option<&str> {
    const EXTENSIONS: [&str; 14] = [
        ".rs", ".md", ".toml", ".py", ".js", ".json", ".jsonl", ".sh", ".yaml", ".yml", ".html", ".css",
        ".svg", ".txt",
    ];
    let path = span.strip_prefix("./").unwrap_or(span);
    let path_like = !path.is_empty()
        && path.chars().all(|c| c.is_ascii_alphanumeric() || "_.-/".contains(c))
        && (EXTENSIONS.iter().any(|e| path.ends_with(e)) || path.ends_with('/'));
    let placeholder =
        path.split('/').any(|part| part.len() > 1 && part.chars().all(|c| c.is_ascii_uppercase()));
    (path_like && !placeholder).then_some(path)
}

/// Whether `path`, named in `document`, is in the tree: from the document's folder or the
/// root; a repository path (one whose first folder is the root's) only so; a Rust module
/// (`game/motion.rs`) also as the end of a path.
fn exists(tree: &BTreeSet<String>, document: &str, path: &str) -> Result<(), String> {
    let path = path.trim_end_matches('/');
    let folder = Path::new(document).parent().map(|p| p.to_string_lossy().into_owned()).unwrap_or_default();
    let from_folder = if folder.is_empty() { path.to_string() } else { format!("{folder}/{path}") };
    if tree.contains(path) || tree.contains(&from_folder) {
        return Ok(());
    }
    let first = path.split('/').next().unwrap_or_default();
    let repository_path = path.contains('/') && tree.contains(first);
    let module = path.ends_with(".rs") && tree.iter().any(|p| p.ends_with(&format!("/{path}")));
    if !repository_path && (module || !path.ends_with(".rs")) {
        return Ok(());
    }
    Err(format!("{document} names `{path}`, which is not in the repository"))
}

#[test]
fn every_path_the_documents_name_exists() {
    let tree = tree();
    let mut checked = 0;
    let mut missing = Vec::new();
    for (document, text) in document_texts() {
        for span in text.split('`').skip(1).step_by(2) {
            if let Some(path) = named_path(span) {
                checked += 1;
                missing.extend(exists(&tree, &document, path).err());
            }
        }
    }
    assert!(checked > 200, "only {checked} paths found: the reading is broken");
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// The relative targets of a document's Markdown links (`[text](target)`), without anchors.
fn link_targets(text: &str) -> Vec<&str> {
    text.split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .map(|target| target.split('#').next().unwrap_or_default())
        .filter(|target| !target.is_empty() && !target.contains(':') && !target.contains(' '))
        .collect()
}

#[test]
fn every_relative_link_of_the_documents_leads_somewhere() {
    let tree = tree();
    let mut checked = 0;
    let mut broken = Vec::new();
    for (document, text) in document_texts() {
        let folder = Path::new(&document).parent().unwrap_or(Path::new(""));
        for target in link_targets(&text) {
            checked += 1;
            let path = folder.join(target);
            let normal = path.components().fold(PathBuf::new(), |mut at, part| {
                match part {
                    std::path::Component::ParentDir => {
                        at.pop();
                    }
                    std::path::Component::CurDir => {}
                    other => at.push(other),
                }
                at
            });
            let normal = normal.to_string_lossy().replace('\\', "/");
            if !tree.contains(normal.trim_end_matches('/')) {
                broken.push(format!("{document} links to `{target}`, which is not in the repository"));
            }
        }
    }
    assert!(checked > 30, "only {checked} links found: the reading is broken");
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

#[test]
fn the_index_of_guides_names_every_guide() {
    let index = std::fs::read_to_string(root().join("docs/README.md")).expect("docs/README.md");
    let linked = link_targets(&index);
    for entry in std::fs::read_dir(root().join("docs")).expect("docs/") {
        let name = entry.expect("an entry").file_name().to_string_lossy().into_owned();
        if name.ends_with(".md") && name != "README.md" {
            assert!(linked.contains(&name.as_str()), "docs/README.md does not link {name}");
        }
    }
    for guide in
        ["../protocol/PROTOCOL.md", "../protocol/README.md", "../python/README.md", "../maps/README.md"]
    {
        assert!(linked.contains(&guide), "docs/README.md does not link {guide}");
    }
    assert_eq!(link_targets("[a](b.md#x) [c](https://e.org) [d](../f/)"), ["b.md", "../f/"]);
}

/// The README is a front door that fits on two screens; the rest belongs in the guides.
#[test]
fn the_readme_is_short() {
    const MOST_LINES: usize = 160;
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let lines = readme.lines().count();
    assert!(
        lines <= MOST_LINES,
        "README.md has {lines} lines, more than {MOST_LINES}: move the details to docs/"
    );
}

#[test]
fn a_renamed_file_is_caught() {
    let tree = tree();
    assert!(exists(&tree, "ARCHITECTURE.md", "crates/bw4t-sim/src/physics.rs").is_ok());
    assert!(exists(&tree, "ARCHITECTURE.md", "game/motion.rs").is_ok());
    assert!(exists(&tree, "python/README.md", "examples/train_ppo.py").is_ok());
    assert!(exists(&tree, "ARCHITECTURE.md", "coop.rs").is_err());
    assert!(exists(&tree, "ARCHITECTURE.md", "crates/bw4t-sim/src/gone.rs").is_err());
    assert!(exists(&tree, "README.md", "docs/GONE.md").is_err());
    assert_eq!(named_path("OUT/row.json"), None);
    assert_eq!(named_path("bw4t run --seed 3"), None);
    assert_eq!(named_path("./test.sh"), Some("test.sh"));
}

#[test]
fn every_crate_has_its_section_in_the_code_map() {
    let architecture = std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let mut crates = 0;
    for entry in std::fs::read_dir(root().join("crates")).expect("crates/") {
        let name = entry.expect("an entry").file_name().to_string_lossy().into_owned();
        crates += 1;
        let heading = format!("\n### `{name}`");
        let has_section = architecture
            .match_indices(&heading)
            .any(|(at, _)| architecture[at + heading.len()..].starts_with(['\n', ' ']));
        assert!(has_section, "ARCHITECTURE.md has no section `### `{name}``");
    }
    assert!(crates >= 10, "{crates} crates");
}

/// The commands a `--help` lists (without `help`).
fn commands_in_help(args: &[&str]) -> Vec<String> {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args(args)
        .arg("--help")
        .output()
        .expect("bw4t");
    assert!(out.status.success(), "bw4t {args:?} --help failed");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.split("\nCommands:\n")
        .nth(1)
        .map(|list| {
            list.lines()
                .take_while(|line| !line.trim().is_empty())
                .filter_map(|line| line.split_whitespace().next())
                .filter(|name| *name != "help")
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn the_command_reference_names_every_command() {
    let reference = std::fs::read_to_string(root().join("docs/COMMANDS.md")).expect("docs/COMMANDS.md");
    let commands = commands_in_help(&[]);
    assert!(commands.len() >= 9, "{commands:?}");
    let mut named = 0;
    for command in &commands {
        let mut lines = vec![format!("bw4t {command}")];
        lines.extend(commands_in_help(&[command]).iter().map(|sub| format!("bw4t {command} {sub}")));
        for line in lines {
            named += 1;
            assert!(reference.contains(&format!("| `{line}` |")), "docs/COMMANDS.md has no row for `{line}`");
        }
    }
    assert!(named > 20, "{named} commands");
}
