//! The layering of docs/architecture.md, read from the code: which top-level modules of `src/`
//! name which others (`crate::TOP` in non-test code), checked against the allowed directions.
//! A text scan, like a reader's: comments and everything after a file's first `#[cfg(test)]`
//! are ignored.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const MODEL: &[&str] = &[
    "geometry",
    "lightfield",
    "refocus",
    "scene",
    "depth",
    "synth",
    "color",
    "io",
];
const FRONT_ENDS: &[&str] = &["cli", "viewer", "bench"];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable src/") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Top-level module → the top-level modules its non-test code names.
fn module_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let top = first.trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap();
        let edges = graph.entry(top.clone()).or_default();
        for line in code.lines() {
            let line = line.split("//").next().unwrap();
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() && name != top {
                    edges.insert(name);
                }
            }
        }
    }
    graph
}

#[test]
fn layers_import_only_downwards() {
    let graph = module_graph();
    let mut forbidden: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for m in MODEL {
        let mut f = vec!["gpu", "passes", "jobs"];
        f.extend(FRONT_ENDS);
        forbidden.insert(m, f);
    }
    // Geometry is pure maths: it names no other model module either.
    forbidden
        .get_mut("geometry")
        .unwrap()
        .extend(MODEL.iter().filter(|m| **m != "geometry"));
    // The depth estimator is evaluated on synthetic scenes, but those live with the other test
    // sets (`bench`): the model itself renders nothing.
    forbidden.get_mut("depth").unwrap().push("synth");
    let mut gpu = vec!["passes", "jobs"];
    gpu.extend(MODEL);
    gpu.extend(FRONT_ENDS);
    forbidden.insert("gpu", gpu);
    let mut passes = vec!["jobs"];
    passes.extend(FRONT_ENDS);
    forbidden.insert("passes", passes);
    forbidden.insert("jobs", FRONT_ENDS.to_vec());
    forbidden.insert("viewer", vec!["bench"]);
    forbidden.insert("bench", vec!["viewer"]);
    assert!(graph.contains_key("jobs") && graph.contains_key("geometry"));
    let mut violations = Vec::new();
    for (from, banned) in &forbidden {
        for to in graph.get(*from).into_iter().flatten() {
            if banned.contains(&to.as_str()) {
                violations.push(format!("{from} -> {to}"));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "imports against the layering: {violations:?}"
    );
}

/// The front ends that only build requests and report results: the command line, the bench and
/// the Python module (its own crate, `python/src`). They name the refocus settings through
/// `refocus::settings`, never through the passes that implement them.
const REQUEST_FRONT_ENDS: &[&str] = &["src/cli", "src/bench", "python/src"];

#[test]
fn request_front_ends_import_no_pass() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut violations = Vec::new();
    for dir in REQUEST_FRONT_ENDS {
        let mut files = Vec::new();
        rust_files(&root.join(dir), &mut files);
        assert!(!files.is_empty(), "no Rust files under {dir}");
        for file in files {
            let rel = file
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .to_string();
            let text = std::fs::read_to_string(&file).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            for (n, line) in code.lines().enumerate() {
                let line = line.split("//").next().unwrap();
                for (i, _) in line.match_indices("passes::") {
                    let path: String = line[i..]
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                        .collect();
                    violations.push(format!("{rel}:{}: {path}", n + 1));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "front ends naming the passes (settings are in refocus::settings): {violations:?}"
    );
}

#[test]
fn no_cycle_between_top_level_modules() {
    let graph = module_graph();
    // Depth-first search for a back edge.
    fn visit<'a>(
        n: &'a str,
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<&'a str, u8>,
        path: &mut Vec<&'a str>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(1) => {
                let start = path.iter().position(|p| *p == n).unwrap();
                return Some(path[start..].iter().map(|s| s.to_string()).collect());
            }
            Some(_) => return None,
            None => {}
        }
        state.insert(n, 1);
        path.push(n);
        for next in graph.get(n).into_iter().flatten() {
            if graph.contains_key(next) {
                if let Some(cycle) = visit(next, graph, state, path) {
                    return Some(cycle);
                }
            }
        }
        path.pop();
        state.insert(n, 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        let mut path = Vec::new();
        if let Some(cycle) = visit(n, &graph, &mut state, &mut path) {
            panic!(
                "import cycle between top-level modules: {}",
                cycle.join(" -> ")
            );
        }
    }
}
