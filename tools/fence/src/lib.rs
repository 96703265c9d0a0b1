//! What the workspace's tests share about its own shape. Fences for a crate's layers: the modules each file names by path
//! (`crate::a::b`, `super::c`, in `use` lines and inside functions alike), checked against the
//! order of the crate's layer folders, and for circles among the modules.
//!
//! Text, not the compiler: a path in a comment or a string counts too, which errs on the side of
//! a fence that holds.

pub mod examples;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A crate's modules and the modules each one names.
#[derive(Debug, Default)]
pub struct ModuleGraph {
    /// By module path (`trace::views`, `lib` for the root), the module paths it names.
    pub names: BTreeMap<String, BTreeSet<String>>,
}

impl ModuleGraph {
    /// Reads every `.rs` file under `src` (a crate's `src` folder, or a folder of modules below
    /// `prefix`, as `editor` for `src/editor`) and the module paths each names.
    pub fn read(src: &Path, prefix: &str) -> ModuleGraph {
        let mut files = Vec::new();
        collect(src, &mut files);
        // Every module and each folder above one (a folder is a module, with or without `mod.rs`).
        let mut modules: BTreeSet<String> = BTreeSet::new();
        for f in &files {
            let m = module_of(src, prefix, f);
            let parts: Vec<&str> = m.split("::").collect();
            for n in 1..=parts.len() {
                modules.insert(parts[..n].join("::"));
            }
        }
        let mut names = BTreeMap::new();
        for file in &files {
            let module = module_of(src, prefix, file);
            let text = std::fs::read_to_string(file).expect("a source file");
            let named = named_modules(&text, &module, &modules, prefix);
            names.insert(module, named);
        }
        ModuleGraph { names }
    }

    /// Each `(module, named)` pair where a module of a layer names a module of a layer above it:
    /// `layers` lists the crate's top folders lowest first (a module outside them is above all).
    pub fn upward(&self, layers: &[&str]) -> Vec<(String, String)> {
        let rank = |m: &str| {
            let top = m.split("::").next().unwrap_or_default();
            layers
                .iter()
                .position(|l| *l == top)
                .unwrap_or(layers.len())
        };
        let mut found = Vec::new();
        for (module, named) in &self.names {
            for n in named {
                if rank(n) > rank(module) {
                    found.push((module.clone(), n.clone()));
                }
            }
        }
        found
    }

    /// The circles among the modules: each a list of modules, each naming the next, the last
    /// naming the first (a module's own `mod` children named by it do not count).
    pub fn circles(&self) -> Vec<Vec<String>> {
        // Tarjan's strongly connected components, iteratively.
        let keys: Vec<&String> = self.names.keys().collect();
        let index_of: BTreeMap<&str, usize> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (k.as_str(), i))
            .collect();
        let edges: Vec<Vec<usize>> = keys
            .iter()
            .map(|k| {
                self.names[*k]
                    .iter()
                    .filter_map(|n| index_of.get(n.as_str()).copied())
                    .collect()
            })
            .collect();
        strongly_connected(&edges)
            .into_iter()
            .filter(|c| c.len() > 1)
            .map(|c| c.into_iter().map(|i| keys[i].clone()).collect())
            .collect()
    }
}

/// Fails, naming them, if the modules under `src` (a crate's `src`, `prefix` as for
/// [`ModuleGraph::read`]) form a circle.
pub fn assert_no_circles(src: &Path, prefix: &str) {
    let circles = ModuleGraph::read(src, prefix).circles();
    assert!(
        circles.is_empty(),
        "{}: modules naming each other, through others too: {circles:?}",
        src.display()
    );
}

/// Fails, naming them, if a module under `src` names a layer above its own (`layers` lowest first;
/// the crate's root, `lib`, counts as above all), or lies outside the layers (`lib` aside).
pub fn assert_layers(src: &Path, prefix: &str, layers: &[&str]) {
    let g = ModuleGraph::read(src, prefix);
    let upward = g.upward(layers);
    assert!(
        upward.is_empty(),
        "{}: modules naming a higher layer: {upward:?}",
        src.display()
    );
    let depth = usize::from(!prefix.is_empty());
    let outside: Vec<&String> = g
        .names
        .keys()
        .filter(|m| {
            *m != "lib"
                && *m != prefix
                && !layers.contains(&m.split("::").nth(depth).unwrap_or_default())
        })
        .collect();
    assert!(
        outside.is_empty(),
        "{}: modules outside the layers {layers:?}: {outside:?}",
        src.display()
    );
}

/// Fails, naming them, if a module under `src` names a folder it may not: `layers` lists groups
/// of peer folders, lowest first (as `[["core"], ["input", "viewport"], ["workspace"]]`). A module
/// may name its own folder and any folder of a lower layer, never a peer of its own layer nor a
/// folder above; a module outside every folder (the root, `prefix` itself) may name any.
pub fn assert_peers_apart(src: &Path, prefix: &str, layers: &[&[&str]]) {
    let g = ModuleGraph::read(src, prefix);
    let depth = usize::from(!prefix.is_empty());
    let place = |m: &str| {
        let folder = m.split("::").nth(depth).unwrap_or_default().to_owned();
        let layer = layers.iter().position(|l| l.contains(&folder.as_str()));
        (folder, layer)
    };
    let mut found = Vec::new();
    for (module, named) in &g.names {
        let (folder, Some(layer)) = place(module) else {
            continue;
        };
        for n in named {
            match place(n) {
                (f, Some(l)) if l > layer || (l == layer && f != folder) => {
                    found.push((module.clone(), n.clone()))
                }
                _ => {}
            }
        }
    }
    assert!(
        found.is_empty(),
        "{}: modules naming a peer or a higher layer: {found:?}",
        src.display()
    );
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .expect("a source folder")
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            collect(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// `a::b` for `src/a/b.rs` and `src/a/b/mod.rs`, `lib` for `src/lib.rs`, under `prefix`.
fn module_of(src: &Path, prefix: &str, file: &Path) -> String {
    let rel = file
        .strip_prefix(src)
        .expect("under src")
        .with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    if !prefix.is_empty() {
        parts.insert(0, prefix.to_owned());
    }
    if parts.is_empty() || (parts.len() == 1 && (parts[0] == "lib" || parts[0] == "main")) {
        return "lib".into();
    }
    parts.join("::")
}

/// The modules of `modules` that `text` (module `module`'s file) names by a `crate::` or
/// `super::` path, each the longest module the path reaches (`lib` for an item of the root, as a
/// re-export there); its own children and parents do not count.
fn named_modules(
    text: &str,
    module: &str,
    modules: &BTreeSet<String>,
    prefix: &str,
) -> BTreeSet<String> {
    let mut named = BTreeSet::new();
    let own: Vec<&str> = if module == "lib" {
        Vec::new()
    } else {
        module.split("::").collect()
    };
    for (at, _) in text
        .match_indices("crate::")
        .chain(text.match_indices("super::"))
    {
        if at > 0 && is_ident(text.as_bytes()[at - 1]) {
            continue;
        }
        let path: Vec<&str> = text[at..]
            .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
            .next()
            .unwrap_or_default()
            .split("::")
            .filter(|s| !s.is_empty())
            .collect();
        let mut base: Vec<&str> = Vec::new();
        let mut rest = &path[..];
        if rest.first() == Some(&"crate") {
            rest = &rest[1..];
            // Below a prefix (`editor` for `src/editor`), the crate's paths start with it.
            if !prefix.is_empty() {
                if rest.first() != Some(&prefix) {
                    continue;
                }
                rest = &rest[1..];
                base.push(prefix);
            }
        } else {
            base = own.clone();
            // A file's `super` is its parent module: `a/b.rs`'s is `a`.
            while rest.first() == Some(&"super") {
                base.pop();
                rest = &rest[1..];
            }
        }
        // A `crate::` path whose first part is no module names an item of the crate's root.
        if path.first() == Some(&"crate")
            && prefix.is_empty()
            && rest.first().is_some_and(|first| !modules.contains(*first))
        {
            if module != "lib" {
                named.insert("lib".to_owned());
            }
            continue;
        }
        let mut best = None;
        let mut candidate = base.clone();
        for part in rest {
            candidate.push(part);
            let joined = candidate.join("::");
            if modules.contains(&joined) {
                best = Some(joined);
            } else {
                break;
            }
        }
        if let Some(m) = best
            && m != module
            && !m.starts_with(&format!("{module}::"))
            && !module.starts_with(&format!("{m}::"))
        {
            named.insert(m);
        }
    }
    named
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || b == b':'
}

/// Tarjan's algorithm without recursion: the components, each a list of node indices.
fn strongly_connected(edges: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = edges.len();
    let (mut index, mut low, mut on_stack) = (vec![usize::MAX; n], vec![0; n], vec![false; n]);
    let (mut stack, mut out, mut next) = (Vec::new(), Vec::new(), 0);
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut calls = vec![(root, 0usize)];
        while let Some(&mut (v, ref mut child)) = calls.last_mut() {
            if *child == 0 {
                index[v] = next;
                low[v] = next;
                next += 1;
                stack.push(v);
                on_stack[v] = true;
            }
            if let Some(&w) = edges[v].get(*child) {
                *child += 1;
                if index[w] == usize::MAX {
                    calls.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            calls.pop();
            if let Some(&(parent, _)) = calls.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                out.push(component);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(files: &[(&str, &str)]) -> ModuleGraph {
        let dir =
            std::env::temp_dir().join(format!("fence-{}-{}", std::process::id(), files.len()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let p = dir.join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        let g = ModuleGraph::read(&dir, "");
        std::fs::remove_dir_all(&dir).unwrap();
        g
    }

    #[test]
    fn an_upward_path_and_a_circle_are_found_and_a_clean_crate_passes() {
        let g = graph(&[
            ("lib.rs", "mod low; mod high;"),
            ("low/mod.rs", "pub mod a; pub mod b;"),
            ("low/a.rs", "use crate::low::b::X;"),
            ("low/b.rs", "fn f() { super::a::g(); }"),
            ("high/mod.rs", "pub mod c;"),
            ("high/c.rs", "use crate::low::a::Y;"),
        ]);
        assert_eq!(g.upward(&["low", "high"]), Vec::<(String, String)>::new());
        assert_eq!(
            g.circles(),
            vec![vec!["low::b".to_string(), "low::a".to_string()]]
        );
        let g = graph(&[
            ("lib.rs", "pub use low::a::Z;"),
            ("low/a.rs", "fn f() { crate::high::c::h() }"),
            ("low/b.rs", "/// [`crate::Z`]"),
            ("high/c.rs", ""),
        ]);
        assert_eq!(
            g.upward(&["low", "high"]),
            vec![
                ("low::a".to_string(), "high::c".to_string()),
                ("low::b".to_string(), "lib".to_string())
            ]
        );
        assert!(g.circles().is_empty());
    }
}
