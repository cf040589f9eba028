//! The shape of the workspace, read from its files: the library crates have no command-line
//! dependency, no crate re-exports another, no two modules of a crate name each other, and no
//! function or file is too long to read (engine/ARCHITECTURE.md).
use std::path::{Path, PathBuf};

use scratchart_tests::workspace_root;

/// The library crates: they never print, never exit and have no command-line dependency.
const LIBRARIES: &[&str] = &[
    "engine/exit",
    "engine/observe",
    "engine/model",
    "engine/glsl",
    "engine/tool",
    "engine/machine",
    "engine/vulkan",
    "engine/render",
    "engine/optim",
    "engine/design",
];

/// What only a program may depend on.
const PROGRAM_ONLY: &[&str] = &["clap", "anyhow", "indicatif", "ctrlc"];

/// The longest function and the longest file, lines.
const MAX_FN_LINES: usize = 150;
const MAX_FILE_LINES: usize = 700;

/// The names in a Cargo.toml's `[dependencies]` table.
fn dependencies(manifest: &str) -> Vec<String> {
    let mut inside = false;
    let mut names = Vec::new();
    for line in manifest.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            inside = t == "[dependencies]";
            continue;
        }
        if inside && !t.is_empty() && !t.starts_with('#') {
            if let Some((name, _)) = t.split_once('=') {
                names.push(name.trim().split('.').next().unwrap().to_string());
            }
        }
    }
    names
}

#[test]
fn library_crates_have_no_command_line_dependency() {
    let root = workspace_root();
    for lib in LIBRARIES {
        let manifest = std::fs::read_to_string(root.join(lib).join("Cargo.toml")).unwrap();
        let deps = dependencies(&manifest);
        assert!(
            !deps.is_empty() || ["engine/exit", "engine/observe"].contains(lib),
            "{lib}: no dependencies read"
        );
        for d in &deps {
            assert!(
                !PROGRAM_ONLY.contains(&d.as_str()),
                "{lib} depends on {d}, which only a program may (engine/ARCHITECTURE.md)"
            );
        }
    }
    // The reader itself: it sees the program's dependencies.
    let program = dependencies(&std::fs::read_to_string(root.join("engine/Cargo.toml")).unwrap());
    assert!(
        program.iter().any(|d| d == "clap"),
        "engine/Cargo.toml's dependencies not read: {program:?}"
    );
}

/// Every Rust source of the workspace (the build's own output left out).
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if p.is_dir() {
            if name != "target" && !name.starts_with('.') {
                sources(&p, out);
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
}

fn all_sources() -> Vec<(String, String)> {
    let root = workspace_root();
    let mut files = Vec::new();
    for top in ["engine", "viewer", "calibration", "tests"] {
        sources(&root.join(top), &mut files);
    }
    assert!(files.len() > 100, "only {} sources found", files.len());
    files
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(&root).unwrap().to_string_lossy().to_string();
            (rel, std::fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// No crate re-exports another, and no module re-exports a sibling's items (an old path kept
/// alive): a name is imported from where it lives. (A module may still gather its own private
/// submodules' items, `pub use homography::apply`.)
#[test]
fn no_crate_re_exports_another() {
    let offenders: Vec<String> = all_sources()
        .iter()
        .flat_map(|(f, text)| {
            text.lines()
                .enumerate()
                .filter(|(_, l)| {
                    let t = l.trim_start();
                    ["pub use scratchart_", "pub use crate::", "pub use super::"]
                        .iter()
                        .any(|p| t.starts_with(p))
                })
                .map(move |(i, l)| format!("{f}:{}: {}", i + 1, l.trim()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "re-exports of another crate or of a sibling module (import it from where it lives instead): {offenders:#?}"
    );
}

/// The functions of a formatted Rust source longer than `max` lines: (line, name, lines). A
/// function runs from its `fn` line to the first line that is its indent and `}` (rustfmt's
/// layout, which the workspace keeps).
fn long_functions(text: &str, max: usize) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut long = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = &l[..l.len() - t.len()];
        let head = t
            .trim_start_matches("pub ")
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("const ")
            .trim_start_matches("unsafe ");
        let Some(rest) = head.strip_prefix("fn ") else { continue };
        if l.trim_end().ends_with(';') {
            continue;
        }
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let close = format!("{indent}}}");
        if let Some(end) = lines[i + 1..].iter().position(|m| *m == close) {
            let n = end + 2;
            if n > max {
                long.push((i + 1, name, n));
            }
        }
    }
    long
}

#[test]
fn no_function_or_file_is_too_long() {
    // The measure itself: a function of 3 lines is 3 lines.
    assert_eq!(
        long_functions("fn a() {\n    x();\n}\n", 2),
        vec![(1, "a".to_string(), 3)]
    );
    let mut offenders = Vec::new();
    for (f, text) in all_sources() {
        let n = text.lines().count();
        if n > MAX_FILE_LINES {
            offenders.push(format!("{f}: {n} lines (at most {MAX_FILE_LINES})"));
        }
        for (line, name, n) in long_functions(&text, MAX_FN_LINES) {
            offenders.push(format!("{f}:{line}: fn {name} is {n} lines (at most {MAX_FN_LINES})"));
        }
    }
    assert!(offenders.is_empty(), "split these: {offenders:#?}");
}

/// A module's path in its crate (`fit/lm.rs` is `["fit", "lm"]`; `lib.rs`, `main.rs` and
/// `mod.rs` are their folder's).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().to_string()).collect();
    if matches!(parts.last().map(String::as_str), Some("lib" | "main" | "mod")) {
        parts.pop();
    }
    parts
}

/// The `crate::a::b` and `super::c` paths a source names outside comments and its tests, each
/// as a module path (`module` is the source's own).
fn named_paths(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let code: String = text
        .split("#[cfg(test)]")
        .next()
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let bytes = code.as_bytes();
    let mut out = Vec::new();
    for start in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(start).map(|k| k + from) {
            from = i + start.len();
            if i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_') {
                continue;
            }
            let mut segs: Vec<String> = Vec::new();
            let mut rest = &code[i..];
            loop {
                let seg: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if seg.is_empty() {
                    break;
                }
                rest = &rest[seg.len()..];
                segs.push(seg);
                match rest.strip_prefix("::") {
                    Some(r) => rest = r,
                    None => break,
                }
            }
            // A module's `super` is its parent (`mod.rs`'s module is its folder).
            let mut base: Vec<String> = Vec::new();
            let mut path = segs.into_iter().peekable();
            if path.next().as_deref() == Some("super") {
                base = module[..module.len().saturating_sub(1)].to_vec();
                while path.peek().map(String::as_str) == Some("super") {
                    path.next();
                    base.pop();
                }
            }
            base.extend(path.take_while(|s| s.chars().next().is_some_and(|c| c.is_ascii_lowercase() || c == '_')));
            out.push(base);
        }
    }
    out
}

/// Circles between sibling modules of one crate (`a` names `b` and `b` names `a`, directly or
/// through others): each as the modules on it.
fn module_circles(src: &Path) -> Vec<Vec<String>> {
    let mut files = Vec::new();
    sources(src, &mut files);
    let modules: Vec<(Vec<String>, PathBuf)> = files.iter().map(|f| (module_path(src, f), f.clone())).collect();
    let known: std::collections::HashSet<&Vec<String>> = modules.iter().map(|(m, _)| m).collect();
    let mut graph: std::collections::BTreeMap<Vec<String>, std::collections::BTreeSet<Vec<String>>> =
        Default::default();
    for (m, f) in &modules {
        let text = std::fs::read_to_string(f).unwrap();
        for full in named_paths(&text, m) {
            // The longest prefix that is a module.
            let Some(b) = (1..=full.len())
                .rev()
                .map(|k| full[..k].to_vec())
                .find(|p| known.contains(p))
            else {
                continue;
            };
            let k = m.iter().zip(&b).take_while(|(x, y)| x == y).count();
            if k >= m.len() || k >= b.len() {
                continue; // an ancestor or a descendant
            }
            graph.entry(m[..=k].to_vec()).or_default().insert(b[..=k].to_vec());
        }
    }
    let reaches = |from: &Vec<String>, to: &Vec<String>| {
        let mut seen = std::collections::BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(x) = stack.pop() {
            if &x == to {
                return true;
            }
            if seen.insert(x.clone()) {
                stack.extend(graph.get(&x).into_iter().flatten().cloned());
            }
        }
        false
    };
    let mut circles = Vec::new();
    for (a, bs) in &graph {
        for b in bs {
            if a < b && reaches(b, a) {
                circles.push(vec![a.join("::"), b.join("::")]);
            }
        }
    }
    circles
}

#[test]
fn no_module_circle() {
    // The finder itself: two modules that name each other are a circle.
    let dir = std::env::temp_dir().join(format!("house-circle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("lib.rs"), "mod a;\nmod b;\n").unwrap();
    std::fs::write(dir.join("a.rs"), "use crate::b::x;\n").unwrap();
    std::fs::write(dir.join("b.rs"), "pub fn x() { super::a::y() }\n").unwrap();
    assert_eq!(module_circles(&dir), vec![vec!["a".to_string(), "b".to_string()]]);
    std::fs::remove_dir_all(&dir).unwrap();

    let root = workspace_root();
    let mut crates = Vec::new();
    for top in ["engine", "viewer", "calibration", "tests"] {
        let t = root.join(top);
        if t.join("src").is_dir() {
            crates.push(t.join("src"));
        }
        for e in std::fs::read_dir(&t).unwrap() {
            let p = e.unwrap().path().join("src");
            if p.is_dir() {
                crates.push(p);
            }
        }
    }
    assert!(crates.len() >= 12, "crates found: {crates:?}");
    let found: Vec<String> = crates
        .iter()
        .flat_map(|src| {
            module_circles(src)
                .into_iter()
                .map(move |c| format!("{}: {}", src.display(), c.join(" <-> ")))
        })
        .collect();
    assert!(
        found.is_empty(),
        "module circles (move what both need below both): {found:#?}"
    );
}
