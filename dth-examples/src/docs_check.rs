//! The documentation kept true: every `dth` command a page shows in a shell block is one the
//! command accepts (and the scene files it names exist), and every relative link and image
//! of every page resolves to a file, and its `#anchor` to a heading or an `<a id>` there.
//! (The command summaries, the catalogue and the errors shown are held to what `dth` prints by
//! `tests/docs_match_commands.rs`; the gallery to its manifest by `gallery`'s tests.)

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The pages: the READMEs and everything under `docs/`.
fn pages() -> Vec<PathBuf> {
    let root = root();
    let mut pages = vec![root.join("README.md"), root.join("dth-examples/README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Per line of `text`, the code block it belongs to: `Some(info)` (the opening fence's info
/// string, `sh`, `rust`, ...) for a fence and the lines between, `None` for prose.
fn code_blocks(text: &str) -> Vec<Option<&str>> {
    let mut open: Option<&str> = None;
    text.lines()
        .map(|line| match line.trim_start().strip_prefix("```") {
            Some(info) => match open.take() {
                None => {
                    open = Some(info.trim());
                    open
                }
                closed => closed,
            },
            None => open,
        })
        .collect()
}

/// `(line number, line)` of the lines inside fenced blocks of `lang` (```` ```sh ````).
fn fenced<'a>(text: &'a str, lang: &str) -> Vec<(usize, &'a str)> {
    text.lines()
        .zip(code_blocks(text))
        .enumerate()
        .filter(|(_, (line, block))| *block == Some(lang) && !line.trim_start().starts_with("```"))
        .map(|(i, (line, _))| (i + 1, line))
        .collect()
}

/// The arguments of a shell line that runs the `dth` command (`cargo run --release -- ARGS`,
/// `cargo run --release`, `dth ARGS`, `... dth-mpi ARGS`), split as the shell splits them,
/// comments dropped; `None` for other commands.
fn dth_args(line: &str) -> Option<Vec<String>> {
    let words = shlex::split(line)?;
    let words: Vec<String> = words
        .into_iter()
        .take_while(|w| !w.starts_with('#'))
        .collect();
    let start = if words.starts_with(&["cargo".into(), "run".into(), "--release".into()]) {
        if words
            .iter()
            .any(|w| w == "-p" || w.starts_with("--example") || w == "--bin")
        {
            return None; // another binary or an example
        }
        match words.iter().position(|w| w == "--") {
            Some(i) => i + 1,
            None => words.len(),
        }
    } else if words.first().is_some_and(|w| w == "cargo") {
        return None; // cargo build, bench, test, ...
    } else {
        words
            .iter()
            .position(|w| w == "dth" || w.ends_with("/dth") || w.ends_with("dth-mpi"))?
            + 1
    };
    Some(words[start..].to_vec())
}

#[test]
fn every_dth_command_the_docs_show_is_one_dth_accepts() {
    let root = root();
    let mut shown = 0;
    let mut wrong = Vec::new();
    for page in pages() {
        let text = read(&page);
        for (n, line) in fenced(&text, "sh") {
            let Some(args) = dth_args(line) else { continue };
            shown += 1;
            let at = format!("{}:{n}: `{}`", page.display(), line.trim());
            if let Err(e) = crate::cli::accepts(&args) {
                wrong.push(format!("{at}: {}", e.lines().next().unwrap_or_default()));
                continue;
            }
            // A scene the command runs or checks exists (placeholders are in capitals).
            if let [command, scene, ..] = args.as_slice() {
                let named = scene.ends_with(".toml") && !scene.chars().any(char::is_uppercase);
                if (command == "run" || command == "check") && named && !root.join(scene).is_file()
                {
                    wrong.push(format!(
                        "{at}: no scene `{scene}` (from the repository's root)"
                    ));
                }
            }
        }
    }
    assert!(shown >= 10, "only {shown} dth commands found in the docs");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn the_line_splitter_finds_dth_commands() {
    let args = |l: &str| dth_args(l).map(|a| a.join("|"));
    assert_eq!(
        args("cargo run --release -- run a.toml --out x   # a comment").as_deref(),
        Some("run|a.toml|--out|x")
    );
    assert_eq!(args("cargo run --release").as_deref(), Some(""));
    assert_eq!(
        args(r#"cargo run --release -- derive "p1^2 + q1^2""#).as_deref(),
        Some("derive|p1^2 + q1^2")
    );
    assert_eq!(
        args("mpirun -n 4 target/release/dth-mpi run S.toml").as_deref(),
        Some("run|S.toml")
    );
    assert_eq!(args("cargo run --release -p dth --example robust"), None);
    assert_eq!(
        args("cargo build --release -p dth-mpi --features mpi"),
        None
    );
    assert_eq!(args("pip install ./dth-python"), None);
    // A command `dth` refuses is found as one.
    assert!(crate::cli::accepts(&["runn".into()]).is_err());
    assert!(crate::cli::accepts(&["run".into(), "a.toml".into()]).is_ok());
}

/// GitHub's anchor of a heading: lowercase, punctuation other than `-` and `_` dropped,
/// spaces to `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of a page: its headings' slugs (a repeated one numbered `-1`, `-2`, ...) and
/// its `<a id="...">` / `<a name="...">`.
fn anchors(text: &str) -> Vec<String> {
    let mut found: Vec<String> = Vec::new();
    for (line, block) in text.lines().zip(code_blocks(text)) {
        if block.is_some() {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            let base = slug(h.trim_start_matches('#'));
            let mut anchor = base.clone();
            let mut k = 0;
            while found.contains(&anchor) {
                k += 1;
                anchor = format!("{base}-{k}");
            }
            found.push(anchor);
        }
        for key in ["<a id=\"", "<a name=\""] {
            let mut rest = line;
            while let Some(at) = rest.find(key) {
                rest = &rest[at + key.len()..];
                if let Some(end) = rest.find('"') {
                    found.push(rest[..end].to_string());
                }
            }
        }
    }
    found
}

/// The targets of the markdown links and images in `text` outside code: `(line, target)`.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (i, (line, block)) in text.lines().zip(code_blocks(text)).enumerate() {
        if block.is_some() {
            continue;
        }
        // Inline code spans are not links.
        let prose: String = line
            .split('`')
            .enumerate()
            .filter(|(k, _)| k % 2 == 0)
            .map(|(_, s)| s)
            .collect::<Vec<_>>()
            .join(" ");
        let mut rest = prose.as_str();
        while let Some(at) = rest.find("](") {
            rest = &rest[at + 2..];
            if let Some(end) = rest.find(')') {
                found.push((i + 1, rest[..end].to_string()));
            }
        }
    }
    found
}

#[test]
fn every_relative_link_of_the_docs_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = read(&page);
        let dir = page.parent().unwrap_or(Path::new("."));
        for (n, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let path = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            let at = format!("{}:{n}: `{target}`", page.display());
            if !path.exists() {
                broken.push(format!("{at}: no file {}", path.display()));
                continue;
            }
            if let Some(anchor) = anchor {
                let known = path.extension().is_some_and(|e| e == "md")
                    && anchors(&read(&path)).iter().any(|a| a == anchor);
                if !known {
                    broken.push(format!("{at}: no anchor `#{anchor}` in {}", path.display()));
                }
            }
        }
    }
    assert!(checked >= 20, "only {checked} relative links found");
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

#[test]
fn anchors_are_github_slugs() {
    let text = "# A b\n## Kepler e = 0.9: robust DTH\n```\n# not a heading\n```\n## A b\n<a id=\"x\"></a>\n";
    assert_eq!(
        anchors(text),
        ["a-b", "kepler-e--09-robust-dth", "a-b-1", "x"]
    );
    assert_eq!(
        links("see [a](b.md#c) and `[x](y)` and ![f](figures/f.png)"),
        [(1, "b.md#c".to_string()), (1, "figures/f.png".to_string())]
    );
}

#[test]
fn the_docs_index_links_every_page() {
    let docs = root().join("docs");
    let index = read(&docs.join("README.md"));
    let linked: Vec<String> = links(&index).into_iter().map(|(_, t)| t).collect();
    let missing: Vec<String> = pages()
        .iter()
        .filter(|p| p.parent().is_some_and(|d| d.ends_with("docs")))
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .filter(|name| name != "README.md" && !linked.iter().any(|t| t == name))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/README.md does not link {missing:?}"
    );
}

/// An unclosed code fence turns the rest of a page into code (the library guide is also the
/// crate's rustdoc front page, where it would swallow the sections after it).
#[test]
fn every_code_fence_is_closed() {
    for page in pages() {
        let fences = read(&page)
            .lines()
            .filter(|l| l.trim_start().starts_with("```"))
            .count();
        assert!(fences % 2 == 0, "{}: an unclosed ``` fence", page.display());
    }
}
