//! Checks of the source tree itself: the layering ARCHITECTURE.md states (what each layer may not
//! touch), the function-length limit of the platform's edge, and the measures declared once.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(&d).expect("a source directory") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                todo.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

fn src(layer: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join(layer)
}

/// The code of a file without its `#[cfg(test)]` module (tests may use anything).
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).expect("a source file");
    match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => text[..i].to_string(),
        None => text,
    }
}

/// `(file, line, what)` for every use of a forbidden name in a layer's code.
fn uses(layer: &str, forbidden: &[&str]) -> Vec<String> {
    let mut found = Vec::new();
    for file in rust_files(&src(layer)) {
        for (n, line) in code(&file).lines().enumerate() {
            let line = line.split("//").next().unwrap_or("");
            for name in forbidden.iter().filter(|f| line.contains(*f)) {
                found.push(format!("{}:{}: {name}", file.display(), n + 1));
            }
        }
    }
    found
}

#[test]
fn tidy_layers_touch_only_what_architecture_allows() {
    let io = ["std::fs", "File::", "read_dir", "tokio::", "sqlx::", "axum::"];
    assert_eq!(uses("engine", &io), Vec::<String>::new(), "the engine does no I/O");
    assert_eq!(uses("speech", &io), Vec::<String>::new(), "speech does no file I/O: callers write its outputs");
    assert_eq!(uses("laugh", &io), Vec::<String>::new(), "laugh curves and their fit do no file I/O: the CLI reads tracks and writes curves");
    let clock = ["std::fs", "File::", "SystemTime", "Instant::now", "tokio::", "sqlx::", "axum::"];
    assert_eq!(uses("study", &clock), Vec::<String>::new(), "studies are pure logic: no I/O, no clock, no HTTP");
    assert_eq!(uses("analysis", &["sqlx::", "axum::", "tokio::", "crate::db", "crate::web"]), Vec::<String>::new(), "the analysis knows nothing of HTTP or SQLite");
}

/// The functions of a file longer than `max` lines, as `(name, first line, length)`.
fn long_functions(text: &str, max: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(name) = fn_name(line) else { continue };
        let mut depth = 0i64;
        let mut opened = false;
        for (j, body) in lines[i..].iter().enumerate() {
            let body = strip_literals(body);
            if !opened && body.trim_end().ends_with(';') {
                break;
            }
            for c in body.chars() {
                match c {
                    '{' => (depth, opened) = (depth + 1, true),
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            if opened && depth == 0 {
                if j + 1 > max {
                    out.push((name.clone(), i + 1, j + 1));
                }
                break;
            }
        }
    }
    out
}

/// The name of the function a line declares, if it declares one.
fn fn_name(line: &str) -> Option<String> {
    let mut rest = line.trim_start();
    for prefix in ["pub(crate) ", "pub(super) ", "pub ", "async ", "const ", "unsafe "] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    let rest = rest.strip_prefix("async ").unwrap_or(rest).strip_prefix("fn ")?;
    Some(rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect())
}

/// A line without its comment and with string and char literals emptied (so braces in them do not count).
fn strip_literals(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => break,
            '"' => {
                while let Some(d) = chars.next() {
                    match d {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
            }
            '\'' => {
                // A char literal ('{', '\''), or a lifetime ('a): skip only the former.
                let ahead: String = chars.clone().take(3).collect();
                if ahead.starts_with('\\') {
                    chars.by_ref().take_while(|&d| d != '\'').for_each(drop);
                } else if ahead.chars().nth(1) == Some('\'') {
                    chars.next();
                    chars.next();
                }
            }
            c => out.push(c),
        }
    }
    out
}

#[test]
fn tidy_no_function_of_the_platform_edge_is_longer_than_80_lines() {
    let mut long = Vec::new();
    for layer in ["web", "db", "analysis", "report"] {
        for file in rust_files(&src(layer)) {
            let text = std::fs::read_to_string(&file).expect("a source file");
            long.extend(long_functions(&text, 80).into_iter().map(|(name, line, n)| format!("{}:{line} {name}: {n} lines", file.display())));
        }
    }
    assert_eq!(long, Vec::<String>::new());
    // The counter itself: a 3-line function, braces in strings and chars, a declaration without body.
    let sample = "fn short() {\n    let s = \"{{\";\n}\nfn long() {\n    let c = '{';\n    x();\n}\ntrait T { fn f(&self); }\n";
    assert_eq!(long_functions(sample, 2), vec![("short".to_string(), 1, 3), ("long".to_string(), 4, 4)]);
}

#[test]
fn tidy_measure_names_are_written_once() {
    // The names of the measures appear as string literals only in their declaration (and in tests).
    let names = ["\"description_match\"", "\"believability\"", "\"ethnicity\"", "\"education\""];
    let mut found = Vec::new();
    for layer in ["web", "db", "analysis", "report", "study"] {
        for file in rust_files(&src(layer)).into_iter().filter(|f| !f.ends_with("measure.rs")) {
            for (n, line) in code(&file).lines().enumerate() {
                for name in names.iter().filter(|name| line.contains(*name)) {
                    found.push(format!("{}:{}: {name}", file.display(), n + 1));
                }
            }
        }
    }
    assert_eq!(found, Vec::<String>::new());
}

#[test]
fn tidy_every_test_architecture_md_names_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    // Test names are long snake_case sentences in backticks (`module::a_test_that_says_what_holds`).
    let named: Vec<&str> = text
        .split('`')
        .skip(1)
        .step_by(2)
        .filter_map(|quoted| quoted.rsplit("::").next())
        .filter(|name| name.matches('_').count() >= 3 && name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
        .collect();
    assert!(named.len() >= 20, "only {} test names found in ARCHITECTURE.md", named.len());
    let mut sources = String::new();
    for dir in ["src", "tests"] {
        for file in rust_files(&root.join(dir)) {
            sources.push_str(&std::fs::read_to_string(file).expect("a source file"));
        }
    }
    let missing: Vec<&str> = named.into_iter().filter(|name| !sources.contains(&format!("fn {name}("))).collect();
    assert_eq!(missing, Vec::<&str>::new(), "ARCHITECTURE.md names tests that do not exist");
}
