//! The library's layers, arrows pointing down only (docs/how-it-works.md): the core — grid,
//! skin, flow, targets, polygonizer, meshes, particles — imports nothing from the file
//! formats, the frame loop or the measurements above it, and no two modules import each
//! other, directly or around a circle. Read from the sources: a `crate::module` path
//! outside comments and test modules is an import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

mod common;

/// The core: what a Python wheel or another program links without OpenVDB or files.
const CORE: &[&str] = &[
    "budget",
    "field",
    "flow",
    "grid",
    "mesh",
    "particles",
    "polygonize",
    "render",
    "skin",
    "stencil",
    "target",
    "volume",
];

/// The modules above the core.
const ABOVE_CORE: &[&str] = &["frames", "io", "measure", "sequence", "validate", "vdb"];

/// The code of a source file without comments, string contents or `#[cfg(test)]` items.
fn code(text: &str) -> String {
    let mut out = String::new();
    let mut skip_depth: Option<i32> = None;
    let mut depth = 0i32;
    let mut pending_test = false;
    for line in text.lines() {
        let line = match line.find("//") {
            Some(k) => &line[..k],
            None => line,
        };
        let trimmed = line.trim();
        if trimmed.starts_with("#[cfg(test)]") {
            pending_test = true;
            continue;
        }
        if pending_test && !trimmed.is_empty() {
            pending_test = false;
            if trimmed.ends_with(';') {
                continue; // `#[cfg(test)] use …;`
            }
            skip_depth = Some(depth);
        }
        for c in line.chars() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ => {}
            }
        }
        if let Some(d) = skip_depth {
            if depth <= d && line.contains('}') {
                skip_depth = None;
            }
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Each top-level module and the other top-level modules its code names.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for path in common::files_under(&src) {
        if path.extension().and_then(|e| e.to_str()) != Some("rs") {
            continue;
        }
        let relative = path.strip_prefix(&src).unwrap();
        let first = relative.components().next().unwrap();
        let module = first
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if matches!(module.as_str(), "lib" | "main" | "cli" | "bench") {
            continue; // the root's error enum names every stage; the binary is on top
        }
        let text = code(&std::fs::read_to_string(&path).unwrap());
        let names = graph.entry(module.clone()).or_default();
        for (k, _) in text.match_indices("crate::") {
            let rest = &text[k + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && name != module {
                names.insert(name);
            }
        }
    }
    graph
}

#[test]
fn the_core_imports_nothing_above_it() {
    let graph = imports();
    for module in CORE {
        let names = graph
            .get(*module)
            .unwrap_or_else(|| panic!("no module {module}"));
        let above: Vec<&String> = names
            .iter()
            .filter(|n| ABOVE_CORE.contains(&n.as_str()))
            .collect();
        assert!(above.is_empty(), "{module} imports {above:?}");
    }
}

#[test]
fn no_two_modules_import_each_other() {
    let graph = imports();
    // Depth-first search for a circle, reporting its path.
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) {
        if let Some(k) = path.iter().position(|n| n == node) {
            panic!("a circle: {} -> {node}", path[k..].join(" -> "));
        }
        if done.contains(node) {
            return;
        }
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            visit(next, graph, path, done);
        }
        path.pop();
        done.insert(node.to_string());
    }
    let mut done = BTreeSet::new();
    for node in graph.keys() {
        visit(node, &graph, &mut Vec::new(), &mut done);
    }
}

/// The modules of `io/` and the `io` modules each names (`super::ply`, `crate::io::ply`;
/// `vdb/` is part of `vdb`), with the root `io.rs` as the node `io`: a file naming an item
/// of the root (`super::has_extension`) points at it, the root naming a module's item
/// (`ply::read_ply`) points down at that module; `pub mod` lines are not imports, nor
/// the root's `pub use` re-exports for the crate's callers.
fn io_imports() -> BTreeMap<String, BTreeSet<String>> {
    let io = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/io");
    let mut modules: Vec<String> = std::fs::read_dir(&io)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    modules.sort();
    let named = |text: &str, prefix: &str| -> BTreeSet<String> {
        let mut names = BTreeSet::new();
        for (k, _) in text.match_indices(prefix) {
            // `xsuper::` or `my_ply::` are not these paths.
            if text[..k].ends_with(|c: char| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let rest = &text[k + prefix.len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            names.insert(name);
        }
        names
    };
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for module in &modules {
        let mut text = code(&std::fs::read_to_string(io.join(format!("{module}.rs"))).unwrap());
        let folder = io.join(module);
        if folder.is_dir() {
            for entry in std::fs::read_dir(&folder).unwrap() {
                text += &code(&std::fs::read_to_string(entry.unwrap().path()).unwrap());
            }
        }
        let mut names = named(&text, "crate::io::");
        if !folder.is_dir() {
            names.extend(named(&text, "super::"));
        }
        let edges = graph.entry(module.clone()).or_default();
        for name in names {
            if modules.contains(&name) {
                if &name != module {
                    edges.insert(name);
                }
            } else if !name.is_empty() {
                edges.insert("io".to_string());
            }
        }
    }
    let root = code(&std::fs::read_to_string(io.with_extension("rs")).unwrap());
    let root: String = root
        .lines()
        .filter(|line| !line.trim_start().starts_with("#["))
        .collect::<Vec<_>>()
        .join("\n")
        .split(';')
        .filter(|statement| {
            let s = statement.trim_start();
            !(s.starts_with("pub mod") || s.starts_with("mod") || s.starts_with("pub use"))
        })
        .collect();
    let edges = graph.entry("io".to_string()).or_default();
    for module in &modules {
        if !named(&root, &format!("{module}::")).is_empty() {
            edges.insert(module.clone());
        }
    }
    graph
}

/// A circle in `graph`, as its path, if any.
fn circle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<String> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<String> {
        if let Some(k) = path.iter().position(|n| n == node) {
            return Some(format!("{} -> {node}", path[k..].join(" -> ")));
        }
        if done.contains(node) {
            return None;
        }
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(found) = visit(next, graph, path, done) {
                return Some(found);
            }
        }
        path.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|node| visit(node, graph, &mut Vec::new(), &mut done))
}

/// Inside `io/` too (issue 50): no two formats import each other, no format imports the
/// dispatchers above it (`mesh`, `particles`, `image`), and nothing reaches the crate's
/// `vdb` through the crate root.
#[test]
fn io_has_no_circle_and_no_arrow_up() {
    let graph = io_imports();
    assert!(graph.len() > 15, "{graph:?}");
    assert_eq!(circle(&graph), None, "{graph:?}");
    let dispatchers = ["mesh", "particles", "image"];
    for (module, names) in &graph {
        if dispatchers.contains(&module.as_str()) {
            continue;
        }
        let up: Vec<&String> = names
            .iter()
            .filter(|n| dispatchers.contains(&n.as_str()))
            .collect();
        assert!(up.is_empty(), "io::{module} imports {up:?}");
    }
    // The leaves every format shares import no format.
    for leaf in ["file", "points", "scalar", "mesh_write"] {
        assert!(
            graph[leaf].iter().all(|n| n == "file" || n == "scalar"),
            "io::{leaf} imports {:?}",
            graph[leaf]
        );
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/io");
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            let text = code(&std::fs::read_to_string(&path).unwrap());
            assert!(
                !text.contains("crate::vdb"),
                "{}: crate::vdb through the crate root",
                path.display()
            );
        }
    }
}

#[test]
fn the_circle_finder_finds_one() {
    let graph: BTreeMap<String, BTreeSet<String>> = [
        ("a", vec!["b"]),
        ("b", vec!["c"]),
        ("c", vec!["a"]),
        ("d", vec![]),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.into_iter().map(String::from).collect()))
    .collect();
    assert_eq!(circle(&graph).as_deref(), Some("a -> b -> c -> a"));
}

#[test]
fn the_reader_sees_imports_and_skips_comments_and_tests() {
    let text = "use crate::grid::Aabb;\n/// [`crate::io`]\nfn f() {} // crate::frames\n\
                #[cfg(test)]\nmod tests {\n    use crate::vdb;\n    fn g() { if x { } }\n}\n\
                use crate::flow::Flow;\n";
    let kept = code(text);
    assert!(
        kept.contains("crate::grid") && kept.contains("crate::flow"),
        "{kept}"
    );
    assert!(
        !kept.contains("crate::io") && !kept.contains("crate::frames"),
        "{kept}"
    );
    assert!(!kept.contains("crate::vdb"), "{kept}");
}

/// The `pub` fields of `text` with no doc comment (`///`, or clap's `help = ...`) above
/// them, through their attributes: `name (line)`.
fn undocumented_fields(text: &str) -> Vec<String> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let field = line.trim_start();
        let Some(rest) = field.strip_prefix("pub ") else {
            continue;
        };
        // A field: indented, `pub name: Type`.
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if field.len() == line.len() || name.is_empty() || !rest[name.len()..].starts_with(": ") {
            continue;
        }
        let mut above = lines[..i].iter().rev().map(|l| l.trim());
        let documented = loop {
            match above.next() {
                Some(l) if l.starts_with("///") => break true,
                Some(l) if l.starts_with("#[") && l.contains("help =") => break true,
                Some(l)
                    if l.starts_with("#[") || (l.starts_with("//") && !l.starts_with("///")) => {}
                _ => break false,
            }
        };
        if !documented {
            found.push(format!("{name} (line {})", i + 1));
        }
    }
    found
}

/// Every public field says what it holds (issue 50): a new one without a doc comment
/// fails here.
#[test]
fn every_public_field_is_documented() {
    let mut missing = Vec::new();
    let mut files = Vec::new();
    let mut folders = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("src")];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            match path.is_dir() {
                true => folders.push(path),
                false if path.extension().is_some_and(|e| e == "rs") => files.push(path),
                false => {}
            }
        }
    }
    assert!(files.len() > 50, "{} source files", files.len());
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        for field in undocumented_fields(&text) {
            missing.push(format!("{}: {field}", path.display()));
        }
    }
    assert!(
        missing.is_empty(),
        "undocumented pub fields:\n{}",
        missing.join("\n")
    );
}

#[test]
fn the_field_reader_sees_what_is_undocumented() {
    let text = "pub struct A {\n    /// Said.\n    pub said: u8,\n    #[arg(long)]\n    pub bare: u8,\n    #[arg(long, help = h())]\n    pub helped: u8,\n    /// Said above an attribute.\n    #[arg(long)]\n    // A note.\n    pub noted: u8,\n}\npub fn f(pub_x: u8) {}\n";
    assert_eq!(undocumented_fields(text), ["bare (line 5)"]);
}

/// The settings whose defaults the library owns, as the front ends name them.
const DEFAULTED: &[&str] = &["alpha", "fps", "smooth", "smoothing_length"];

/// The text of every call of `opener` (`signature = (`, `FloatProperty(`) in `text`,
/// to its closing parenthesis.
fn calls<'a>(text: &'a str, opener: &str) -> Vec<&'a str> {
    let mut found = Vec::new();
    for (at, _) in text.match_indices(opener) {
        let body = &text[at + opener.len()..];
        let mut depth = 1;
        let end = body
            .char_indices()
            .find(|&(_, c)| {
                depth += match c {
                    '(' => 1,
                    ')' => -1,
                    _ => 0,
                };
                depth == 0
            })
            .map_or(body.len(), |(i, _)| i);
        found.push(&body[..end]);
    }
    found
}

/// Where `list` (a signature's parameters) gives one of [`DEFAULTED`] a default that is
/// not the library's constant (nor None: the library decides then).
fn literal_defaults(list: &str) -> Vec<String> {
    let flat: String = list.chars().filter(|c| !c.is_whitespace()).collect();
    flat.split(',')
        .filter_map(|param| param.split_once('='))
        .filter(|(name, value)| {
            DEFAULTED.contains(name) && !value.starts_with("DEFAULT_") && *value != "None"
        })
        .map(|(name, value)| format!("{name}={value}"))
        .collect()
}

/// Each default is written once (issue 50): the library defines it, and the command's
/// arguments, the Python signatures and the Blender panel take its value from there.
#[test]
fn each_default_is_written_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let read = |path: &str| std::fs::read_to_string(root.join(path)).unwrap();
    let mut library = String::new();
    let mut folders = vec![root.join("src")];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            match path.is_dir() {
                true => folders.push(path),
                false => library += &std::fs::read_to_string(&path).unwrap(),
            }
        }
    }
    let mut found = Vec::new();
    for name in [
        "DEFAULT_ALPHA",
        "DEFAULT_FPS",
        "DEFAULT_SMOOTHING_LENGTH",
        "DEFAULT_PARTICLE_SMOOTHING",
    ] {
        let defined = library.matches(&format!("const {name}:")).count();
        if defined != 1 {
            found.push(format!("{name} defined {defined} times"));
        }
    }
    // The command: each such argument's default is a library constant.
    for path in ["src/cli/args.rs", "src/cli/particles.rs"] {
        let text = read(path);
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let field = line.trim_start().strip_prefix("pub ").unwrap_or_default();
            let Some(name) = field.split(':').next().filter(|n| DEFAULTED.contains(n)) else {
                continue;
            };
            let attribute = lines[..i]
                .iter()
                .rev()
                .find(|l| l.trim_start().starts_with("#[arg"));
            if let Some(value) = attribute.and_then(|a| a.split("default_value_t =").nth(1)) {
                if !value.contains("DEFAULT_") {
                    found.push(format!("{path}: --{name} defaults to{value}"));
                }
            }
        }
    }
    // Python: the bindings' signatures and the package's functions.
    for path in [
        "python/src/particle_skin.rs",
        "python/src/level_set_skin.rs",
        "python/src/files.rs",
        "python/src/mesh.rs",
    ] {
        for list in calls(&read(path), "signature = (") {
            found.extend(
                literal_defaults(list)
                    .into_iter()
                    .map(|d| format!("{path}: {d}")),
            );
        }
    }
    let package = read("python/activeskin/__init__.py");
    // Each function's parameters: from its name's parenthesis to the closing one.
    let functions = package.match_indices("\ndef ").filter_map(|(at, _)| {
        let open = package[at..].find('(')?;
        calls(&package[at..], "(")
            .into_iter()
            .next()
            .filter(|_| open > 0)
    });
    for list in functions {
        found.extend(
            literal_defaults(list)
                .into_iter()
                .map(|d| format!("activeskin: {d}")),
        );
    }
    // Blender: the panel's properties take the library's defaults as it registers.
    let addon = read("blender/activeskin_blender/__init__.py");
    for name in ["alpha", "smooth"] {
        let property = calls(&addon, &format!("    {name}: bpy.props.FloatProperty("));
        assert_eq!(property.len(), 1, "the add-on's {name}");
        if property[0].contains("default=") {
            found.push(format!("the add-on's {name} has a default of its own"));
        }
    }
    assert!(
        found.is_empty(),
        "defaults written twice:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_default_reader_sees_literals() {
    assert_eq!(
        literal_defaults(
            "radius, *, alpha=4.0, fps=DEFAULT_FPS, smooth=None, smoothing_length = 2"
        ),
        ["alpha=4.0", "smoothing_length=2"]
    );
    assert_eq!(calls("f(a, g(b), c) d(e)", "f("), ["a, g(b), c"]);
}
