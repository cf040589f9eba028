//! The shape of the workspace, read from its files: the library crates have no command-line
//! dependency, no crate re-exports another, and no function or file is too long to read
//! (engine/ARCHITECTURE.md).
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

#[test]
fn no_crate_re_exports_another() {
    let offenders: Vec<String> = all_sources()
        .iter()
        .flat_map(|(f, text)| {
            text.lines()
                .enumerate()
                .filter(|(_, l)| l.trim_start().starts_with("pub use scratchart_"))
                .map(move |(i, l)| format!("{f}:{}: {}", i + 1, l.trim()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "re-exports of another crate (import it where it is used instead): {offenders:#?}"
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
