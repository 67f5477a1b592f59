//! The layers of `src/` as `ARCHITECTURE.md` lists them, held by a test: every `use crate::…`,
//! `use super::…` and inline `crate::…`/`super::…` path is resolved to the file that defines
//! what it names (through a module root's `pub use`), and the test fails on an import from a
//! lower layer into a higher one or on any cycle between files, naming the files and the names
//! taken. Test modules (`#[cfg(test)] mod … { … }`) are left out: they may reach anywhere.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A file's imports: target file → the names taken from it.
type Edges = BTreeMap<String, BTreeSet<String>>;

/// The source files of a crate, by path relative to its `src/` (`render/terrain.rs`).
struct Crate {
    files: BTreeMap<String, String>,
}

impl Crate {
    fn read(src: &Path) -> Crate {
        let mut files = BTreeMap::new();
        let mut stack = vec![src.to_path_buf()];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                let rel = path
                    .strip_prefix(src)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                if path.is_dir() {
                    if rel != "bin" {
                        stack.push(path);
                    }
                } else if rel.ends_with(".rs") {
                    files.insert(rel, std::fs::read_to_string(&path).unwrap());
                }
            }
        }
        Crate { files }
    }

    /// `render/terrain.rs` → `["render", "terrain"]`; `render/mod.rs` → `["render"]`; `lib.rs` → `[]`.
    fn module_of(file: &str) -> Vec<String> {
        let mut parts: Vec<String> = file
            .trim_end_matches(".rs")
            .split('/')
            .map(String::from)
            .collect();
        if parts.last().is_some_and(|p| p == "mod") || parts == ["lib"] {
            parts.pop();
        }
        parts
    }

    fn file_of(&self, module: &[String]) -> Option<&str> {
        self.files
            .keys()
            .map(String::as_str)
            .find(|f| Self::module_of(f) == module)
    }

    /// `path` made absolute from `module`: `crate::`, `self::`, `super::`, or a path through one
    /// of the module's own children (`use terrain::X` in `render/mod.rs`); `None` for other crates.
    fn absolute(&self, path: &[String], module: &[String]) -> Option<Vec<String>> {
        let first = path.first()?;
        if ["crate", "self", "super"].contains(&first.as_str()) {
            return absolute(path, module);
        }
        let child: Vec<String> = module.iter().chain([first]).cloned().collect();
        self.file_of(&child)?;
        Some(module.iter().chain(path).cloned().collect())
    }

    /// The file `path` (absolute module path, `crate::` dropped) lands in, and what is left of it.
    fn resolve(&self, path: &[String]) -> Option<(String, Vec<String>)> {
        let (mut file, mut rest) = (0..=path.len()).rev().find_map(|k| {
            self.file_of(&path[..k])
                .map(|f| (f.to_string(), path[k..].to_vec()))
        })?;
        // Follow a module root's re-export of the first name (`pub use terrain::TerrainRenderer`).
        for _ in 0..4 {
            let Some(first) = rest.first() else { break };
            let Some(target) = self.reexports(&file).remove(first) else {
                break;
            };
            match self.resolve(&target) {
                Some((f, mut r)) if f != file => {
                    r.extend(rest.drain(1..));
                    (file, rest) = (f, r);
                }
                _ => break,
            }
        }
        Some((file, rest))
    }

    /// `pub use` in `file`: exported name → absolute path it re-exports.
    fn reexports(&self, file: &str) -> BTreeMap<String, Vec<String>> {
        let code = strip(&self.files[file]);
        let module = Self::module_of(file);
        let mut out = BTreeMap::new();
        for tree in use_trees(&code, true) {
            for path in expand(&tree) {
                let name = path.last().cloned().unwrap_or_default();
                if let Some(abs) = self.absolute(&path, &module) {
                    out.insert(name, abs);
                }
            }
        }
        out
    }

    /// Every file's imports of other files.
    fn imports(&self) -> BTreeMap<String, Edges> {
        let mut graph = BTreeMap::new();
        for (file, source) in &self.files {
            let code = strip(source);
            let module = Self::module_of(file);
            let mut edges = Edges::new();
            let mut paths: Vec<Vec<String>> = use_trees(&code, false)
                .iter()
                .flat_map(|t| expand(t))
                .collect();
            paths.extend(inline_paths(&code));
            for path in paths {
                let Some(abs) = self.absolute(&path, &module) else {
                    continue;
                };
                let Some((target, rest)) = self.resolve(&abs) else {
                    continue;
                };
                // A root re-exporting its own children is structure, not a dependency.
                let own_child = Self::module_of(&target).starts_with(&module) && target != *file;
                if target != *file && !(own_child && is_reexport(&code, &path)) {
                    let name = if rest.is_empty() {
                        path.last().cloned().unwrap_or_default()
                    } else {
                        rest.join("::")
                    };
                    edges.entry(target).or_default().insert(name);
                }
            }
            graph.insert(file.clone(), edges);
        }
        graph
    }
}

/// The source without comments, string literals and `#[cfg(test)]` modules.
fn strip(source: &str) -> String {
    let mut out = String::with_capacity(source.len());
    let b = source.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if source[i..].starts_with("//") {
            i += source[i..].find('\n').unwrap_or(b.len() - i);
        } else if source[i..].starts_with("/*") {
            i += source[i..].find("*/").map_or(b.len() - i, |e| e + 2);
        } else if b[i] == b'"' && (i == 0 || b[i - 1] != b'\'') {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if source[i..].starts_with("#[cfg(test)]") {
            // Skip the attribute and, when a `mod … {` follows, the whole block.
            let after = i + "#[cfg(test)]".len();
            let rest = source[after..].trim_start();
            let is_mod = rest.starts_with("mod ") || rest.starts_with("pub mod ");
            match (is_mod, source[after..].find('{'), source[after..].find(';')) {
                (true, Some(open), semi) if semi.is_none_or(|s| s > open) => {
                    let mut depth = 0;
                    let mut j = after + open;
                    while j < b.len() {
                        depth += i32::from(b[j] == b'{') - i32::from(b[j] == b'}');
                        j += 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    i = j;
                }
                _ => i = after,
            }
        } else {
            let c = source[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// The trees of every `use` (only `pub use` ones if asked).
fn use_trees(code: &str, only_pub: bool) -> Vec<String> {
    let mut out = Vec::new();
    for stmt in code.split(';') {
        let s = stmt.trim();
        let Some(at) = use_at(s) else { continue };
        if only_pub && !s[..at].contains("pub") {
            continue;
        }
        out.push(s[at + 3..].split_whitespace().collect::<Vec<_>>().join(" "));
    }
    out
}

/// Where the `use` of a statement starts, if the statement (after `;`-splitting) is one: at
/// its start, after a visibility, an attribute or a block's `{`/`}`.
fn use_at(s: &str) -> Option<usize> {
    s.match_indices("use").map(|(i, _)| i).find(|&i| {
        let head = s[..i].trim_end();
        let whole_word =
            !head.ends_with(|c: char| c.is_alphanumeric() || c == '_') || head.ends_with("pub");
        let after = s[i + 3..].chars().next().is_some_and(char::is_whitespace);
        let starts =
            head.is_empty() || head.ends_with("pub") || head.ends_with([')', ']', '{', '}']);
        whole_word && after && starts && s[..i].ends_with(char::is_whitespace) != head.is_empty()
    })
}

/// `a::{b, c::{d, e as f}}` → `[a, b]`, `[a, c, d]`, `[a, c, e]`.
fn expand(tree: &str) -> Vec<Vec<String>> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        let path = tree.split(" as ").next().unwrap();
        return vec![
            path.split("::")
                .map(|p| p.trim().to_string())
                .filter(|p| !p.is_empty())
                .collect(),
        ];
    };
    let prefix: Vec<String> = tree[..open]
        .split("::")
        .map(|p| p.trim().to_string())
        .filter(|p| !p.is_empty())
        .collect();
    let inner = &tree[open + 1..tree.rfind('}').unwrap()];
    let (mut items, mut depth, mut start) = (Vec::new(), 0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    items.push(&inner[start..]);
    items
        .into_iter()
        .filter(|i| !i.trim().is_empty())
        .flat_map(expand)
        .map(|rest| {
            prefix
                .iter()
                .cloned()
                .chain(rest.into_iter().filter(|p| p != "self"))
                .collect()
        })
        .collect()
}

/// `crate::a::b` and `super::x` paths outside `use` statements (not `$crate::`, not
/// `pub(in crate::…)`).
fn inline_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for stmt in code.split(';') {
        let s = stmt.trim();
        let s = use_at(s).map_or(s, |at| &s[..at]);
        for prefix in ["crate::", "super::"] {
            for (at, _) in s.match_indices(prefix) {
                let before = s[..at].chars().next_back();
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$' || c == ':')
                    || s[..at].ends_with("in ")
                {
                    continue;
                }
                let tail = &s[at..];
                let end = tail
                    .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .unwrap_or(tail.len());
                out.push(
                    tail[..end]
                        .split("::")
                        .filter(|p| !p.is_empty())
                        .map(String::from)
                        .collect(),
                );
            }
        }
    }
    out
}

/// A `crate::`/`super::`/`self::` path made absolute (without `crate`) from `module`.
fn absolute(path: &[String], module: &[String]) -> Option<Vec<String>> {
    let (mut base, mut parts) = (module.to_vec(), path);
    match parts.first().map(String::as_str) {
        Some("crate") => base.clear(),
        Some("self") => {}
        Some("super") => {
            while parts.get(1).is_some_and(|p| p == "super") {
                base.pop()?;
                parts = &parts[1..];
            }
            base.pop()?;
        }
        _ => return None,
    }
    Some(base.into_iter().chain(parts[1..].iter().cloned()).collect())
}

fn is_reexport(code: &str, path: &[String]) -> bool {
    use_trees(code, true)
        .iter()
        .flat_map(|t| expand(t))
        .any(|p| p == path)
}

/// The layer of each top-level module, from the table under `## Layers` in ARCHITECTURE.md:
/// rows `| N | `a`, `b` | … |`, lowest layer first.
fn layer_table(architecture: &str) -> BTreeMap<String, u32> {
    let section = format!("\n{architecture}")
        .split("\n## Layers\n")
        .nth(1)
        .expect("ARCHITECTURE.md has no `## Layers` section")
        .to_string();
    let section = section.split("\n## ").next().unwrap();
    let mut layers = BTreeMap::new();
    for row in section.lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
        let Ok(layer) = cells[0].parse::<u32>() else {
            continue;
        };
        for module in cells[1].split(',') {
            let module = module
                .trim()
                .trim_matches('`')
                .trim_end_matches('/')
                .trim_start_matches("src/");
            layers.insert(module.trim_end_matches(".rs").to_string(), layer);
        }
    }
    assert!(
        !layers.is_empty(),
        "the `## Layers` table of ARCHITECTURE.md has no rows"
    );
    layers
}

/// Every import up a layer and every cycle between files, as lines a person can act on.
fn violations(krate: &Crate, layers: &BTreeMap<String, u32>) -> Vec<String> {
    let graph = krate.imports();
    let top = |f: &str| {
        Crate::module_of(f)
            .first()
            .cloned()
            .unwrap_or_else(|| "lib".into())
    };
    let mut out = Vec::new();
    for file in graph.keys() {
        if !layers.contains_key(&top(file)) {
            out.push(format!(
                "src/{file}: module `{}` is in no layer of ARCHITECTURE.md",
                top(file)
            ));
        }
    }
    for (file, edges) in &graph {
        for (target, names) in edges {
            let (from, to) = (layers.get(&top(file)), layers.get(&top(target)));
            if let (Some(from), Some(to)) = (from, to)
                && to > from
            {
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                out.push(format!(
                    "upward import: src/{file} (`{}`, layer {from}) takes {{{}}} from src/{target} (`{}`, layer {to})",
                    top(file),
                    names.join(", "),
                    top(target)
                ));
            }
        }
    }
    for cycle in cycles(&graph) {
        let mut lines = vec![format!("cycle between {} files:", cycle.len())];
        for a in &cycle {
            for (b, names) in &graph[a] {
                if cycle.contains(b) {
                    let names: Vec<&str> = names.iter().map(String::as_str).collect();
                    lines.push(format!("    src/{a} → src/{b} {{{}}}", names.join(", ")));
                }
            }
        }
        out.push(lines.join("\n"));
    }
    out
}

/// The strongly connected components of more than one file (Tarjan's algorithm, iterative).
fn cycles(graph: &BTreeMap<String, Edges>) -> Vec<Vec<String>> {
    let names: Vec<&String> = graph.keys().collect();
    let id: BTreeMap<&String, usize> = names.iter().enumerate().map(|(i, n)| (*n, i)).collect();
    let succ: Vec<Vec<usize>> = names
        .iter()
        .map(|n| {
            graph[*n]
                .keys()
                .filter_map(|t| id.get(t).copied())
                .collect()
        })
        .collect();
    let (mut index, mut low, mut on) = (
        vec![usize::MAX; names.len()],
        vec![0; names.len()],
        vec![false; names.len()],
    );
    let (mut stack, mut out, mut next) = (Vec::new(), Vec::new(), 0);
    for start in 0..names.len() {
        if index[start] != usize::MAX {
            continue;
        }
        let mut work = vec![(start, 0)];
        while let Some(&mut (v, ref mut k)) = work.last_mut() {
            if *k == 0 {
                (index[v], low[v], next) = (next, next, next + 1);
                stack.push(v);
                on[v] = true;
            }
            if let Some(&w) = succ[v].get(*k) {
                *k += 1;
                if index[w] == usize::MAX {
                    work.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(parent, _)) = work.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                while let Some(w) = stack.pop() {
                    on[w] = false;
                    component.push(names[w].clone());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    out.push(component);
                }
            }
        }
    }
    out
}

#[test]
fn src_imports_follow_the_layers_of_architecture_md_without_cycles() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let architecture = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let krate = Crate::read(&root.join("src"));
    let found = violations(&krate, &layer_table(&architecture));
    assert!(
        found.is_empty(),
        "{} layer violations:\n{}",
        found.len(),
        found.join("\n")
    );
}

/// The checker itself, on a small crate with one upward import and one cycle through a
/// re-export: it must name both, or the test above could pass by seeing nothing.
#[test]
fn the_layer_check_names_an_upward_import_and_a_cycle() {
    let files = [
        ("lib.rs", "pub mod low;\npub mod high;\n"),
        ("low/mod.rs", "mod a;\nmod b;\npub use a::Thing;\n"),
        (
            "low/a.rs",
            "use super::b::helper;\npub struct Thing;\nfn f() { crate::high::top(); }\n",
        ),
        (
            "low/b.rs",
            "use crate::low::Thing;\npub fn helper() {}\n#[cfg(test)]\nmod tests { use crate::high::top; }\n",
        ),
        ("high.rs", "pub fn top() {}\n"),
    ];
    let krate = Crate {
        files: files
            .iter()
            .map(|(f, s)| (f.to_string(), s.to_string()))
            .collect(),
    };
    let layers = layer_table(
        "## Layers\n| layer | modules |\n|---|---|\n| 0 | `lib`, `low` |\n| 1 | `high` |\n",
    );
    let found = violations(&krate, &layers);
    assert_eq!(found.len(), 2, "{found:#?}");
    assert!(
        found[0].contains("src/low/a.rs")
            && found[0].contains("{top}")
            && found[0].contains("src/high.rs"),
        "{}",
        found[0]
    );
    assert!(
        found[1].contains("src/low/a.rs → src/low/b.rs {helper}"),
        "{}",
        found[1]
    );
    assert!(
        found[1].contains("src/low/b.rs → src/low/a.rs {Thing}"),
        "{}",
        found[1]
    );
}
