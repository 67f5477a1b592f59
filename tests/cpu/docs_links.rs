//! The documents point at things that exist: every repository path named in backticks in
//! `README.md`, `ARCHITECTURE.md` and `docs/*.md`, every relative markdown link and its
//! `#anchor`, and every `docs/….md#anchor` a source comment cites (in `src/`, `shaders/`,
//! `tests/`, `scripts/`, `data-tools/`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The documents checked: the README, ARCHITECTURE.md and every markdown file under docs/.
fn documents() -> Vec<PathBuf> {
    let mut docs = vec![root().join("README.md"), root().join("ARCHITECTURE.md")];
    let mut stack = vec![root().join("docs")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                docs.push(path);
            }
        }
    }
    docs.sort();
    docs
}

/// GitHub's anchor for a heading: lower case, punctuation dropped except `-` and `_`, spaces
/// to `-`; a repeated heading gets `-1`, `-2`, ….
fn anchors(markdown: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut fenced = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        let Some(title) = line.strip_prefix('#').filter(|_| !fenced) else {
            continue;
        };
        let title = title.trim_start_matches('#').trim();
        let slug: String = title
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let mut unique = slug.clone();
        let mut n = 1;
        while !out.insert(unique.clone()) {
            unique = format!("{slug}-{n}");
            n += 1;
        }
    }
    out
}

/// The top-level entries of the repository: a backticked path starting with one is a
/// repository path (`src/render/`, `Cargo.toml`), anything else (`/usr/share/…`, `target/…`,
/// `tiles/{z}/…`) is not checked.
fn top_level() -> BTreeSet<String> {
    std::fs::read_dir(root())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "target" && n != ".git")
        .collect()
}

/// Backticked spans of `markdown`, fenced blocks left out.
fn code_spans(markdown: &str) -> Vec<&str> {
    let mut spans = Vec::new();
    let mut fenced = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            spans.extend(line.split('`').skip(1).step_by(2));
        }
    }
    spans
}

/// Targets of `[text](target)` links that are not URLs.
fn relative_links(markdown: &str) -> Vec<&str> {
    markdown
        .match_indices("](")
        .filter_map(|(i, _)| markdown[i + 2..].split(')').next())
        .filter(|t| !t.contains("://") && !t.starts_with("mailto:"))
        .collect()
}

/// An error for `target#anchor` (relative to `dir`) unless the file exists and has the anchor.
fn check_target(dir: &Path, target: &str) -> Option<String> {
    let (file, anchor) = target
        .split_once('#')
        .map_or((target, None), |(f, a)| (f, Some(a)));
    let path = if file.is_empty() {
        None
    } else {
        Some(dir.join(file))
    };
    if let Some(path) = &path
        && !path.exists()
    {
        return Some(format!("`{target}`: {} does not exist", path.display()));
    }
    let anchor = anchor?;
    let path = path?;
    let text = std::fs::read_to_string(&path).ok()?;
    (!anchors(&text).contains(anchor))
        .then(|| format!("`{target}`: no heading with anchor #{anchor}"))
}

#[test]
fn every_path_and_anchor_the_documents_name_exists() {
    let top = top_level();
    let mut broken = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        let name = doc.strip_prefix(root()).unwrap().display().to_string();
        let dir = doc.parent().unwrap();
        for span in code_spans(&text) {
            let path = span.split_whitespace().next().unwrap_or("");
            let first = path.split('/').next().unwrap_or("");
            let looks_like_path = path.contains('/') || path.contains('.');
            if looks_like_path
                && top.contains(first)
                && !path.contains(['{', '*', '<', '…'])
                && let Some(e) = check_target(root(), path)
            {
                broken.push(format!("{name}: {e}"));
            }
        }
        for link in relative_links(&text) {
            if let Some(e) = check_target(dir, link) {
                broken.push(format!("{name}: link {e}"));
            }
        }
    }
    assert!(
        broken.is_empty(),
        "{} broken references:\n{}",
        broken.len(),
        broken.join("\n")
    );
}

#[test]
fn every_docs_anchor_a_source_comment_cites_exists() {
    let mut broken = Vec::new();
    let mut stack: Vec<PathBuf> = ["src", "shaders", "tests", "scripts", "data-tools"]
        .iter()
        .map(|d| root().join(d))
        .collect();
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if !path.ends_with("target") && !path.ends_with("fuzz_corpus") {
                    stack.push(path);
                }
                continue;
            }
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            for (i, _) in text.match_indices("docs/") {
                let cite: String = text[i..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || "/._-#".contains(*c))
                    .collect();
                let cite = cite.trim_end_matches(['.', '_', '-']);
                if cite.contains(".md")
                    && let Some(e) = check_target(root(), cite)
                {
                    broken.push(format!(
                        "{}: {e}",
                        path.strip_prefix(root()).unwrap().display()
                    ));
                }
            }
        }
    }
    assert!(
        broken.is_empty(),
        "{} broken citations:\n{}",
        broken.len(),
        broken.join("\n")
    );
}

#[test]
fn anchors_follow_github_slugs() {
    let a = anchors(
        "# Choosing n, m and the texture size\n## The look\n## The look\n```\n# not a heading\n```\n",
    );
    let want: BTreeSet<String> = [
        "choosing-n-m-and-the-texture-size",
        "the-look",
        "the-look-1",
    ]
    .map(String::from)
    .into();
    assert_eq!(a, want);
}

/// The source files the tree must name: `src/`, `shaders/`, `data-tools/src/`, and the test
/// binaries' modules (not their data).
fn tree_files() -> Vec<String> {
    let mut files = Vec::new();
    let mut stack: Vec<PathBuf> = [
        "src",
        "shaders",
        "tests",
        "data-tools/src",
        "data-tools/tests",
    ]
    .iter()
    .map(|d| root().join(d))
    .collect();
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs" || e == "wgsl") {
                files.push(
                    path.strip_prefix(root())
                        .unwrap()
                        .to_string_lossy()
                        .replace('\\', "/"),
                );
            }
        }
    }
    files.sort();
    files
}

/// ARCHITECTURE.md's tree names every source file: a file is named when the block of the
/// longest folder line above it (`src/dem/`, `tests/gpu/`) holds its name (a test module's or
/// a shader's without the extension; a test binary's `main.rs` needs nothing).
#[test]
fn the_architecture_tree_names_every_source_file() {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let tree = text
        .split("\n## Tree\n")
        .nth(1)
        .expect("ARCHITECTURE.md has no `## Tree`");
    let tree = tree.split("\n## ").next().unwrap();
    // Blocks: a line starting at column 0 with a path opens one (several paths may share it).
    let mut blocks: Vec<(Vec<String>, String)> = Vec::new();
    for line in tree.lines() {
        let first = line.split_whitespace().next().unwrap_or("");
        if !line.starts_with(' ') && first.contains('/') {
            let keys = line
                .split("  ")
                .next()
                .unwrap()
                .split(", ")
                .map(|k| k.trim().to_string())
                .collect();
            blocks.push((keys, String::new()));
        }
        if let Some((_, body)) = blocks.last_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    let mut missing = Vec::new();
    for file in tree_files() {
        let block = blocks
            .iter()
            .filter_map(|(keys, body)| {
                keys.iter()
                    .filter(|k| file.starts_with(k.as_str()))
                    .map(|k| (k.len(), body))
                    .max()
            })
            .max_by_key(|(len, _)| *len);
        let name = file.rsplit('/').next().unwrap();
        let stem = name.trim_end_matches(".rs").trim_end_matches(".wgsl");
        let is_test_module = file.starts_with("tests/") || file.starts_with("data-tools/tests/");
        let named = match block {
            Some((len, _)) if file.len() == len => true,
            Some(_) if is_test_module && name == "main.rs" => true,
            Some((len, body)) => {
                let rest = &file[len..];
                let sub_ok = rest
                    .split('/')
                    .rev()
                    .skip(1)
                    .all(|dir| body.contains(&format!("{dir}/")));
                let wanted = if is_test_module || file.ends_with(".wgsl") {
                    stem
                } else {
                    name
                };
                sub_ok && body.contains(wanted)
            }
            None => false,
        };
        if !named {
            missing.push(file);
        }
    }
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md's tree does not name:\n{}",
        missing.join("\n")
    );
}
