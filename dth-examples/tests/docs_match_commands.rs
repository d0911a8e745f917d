//! The READMEs describe what the commands do; these tests hold them to what the commands
//! print, so they cannot go stale: every subcommand and option `dth help` lists is in both
//! command summaries (and nothing else is), the catalogue table and the scene reference name
//! exactly the systems, parameters, methods and effects `dth list` prints, and the errors shown
//! for `dth` on the free particle and for a misspelt parameter of a Hamiltonian given as text
//! are the ones `dth check` prints. (Table 4.1 is held to
//! `dth table41` in `tests/table41.rs`.)

mod common;

use std::collections::BTreeSet;

use common::*;

fn read(path: &str) -> String {
    std::fs::read_to_string(manifest_dir().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The lines of the first fenced block of `lang` after `heading` (or after the start).
fn block<'a>(text: &'a str, heading: &str, lang: &str) -> Vec<&'a str> {
    let from = text
        .find(heading)
        .unwrap_or_else(|| panic!("no `{heading}`"));
    text[from..]
        .lines()
        .skip_while(|l| l.trim() != format!("```{lang}"))
        .skip(1)
        .take_while(|l| !l.starts_with("```"))
        .collect()
}

/// The words that start the indented lines of the section `title:` of a help or list text.
fn section(text: &str, title: &str) -> Vec<String> {
    text.lines()
        .skip_while(|l| l.trim_end() != title)
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

fn help(args: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(args, dir.path());
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// Long options (`--name`) in a text.
fn long_options(text: &str) -> BTreeSet<String> {
    text.split(|c: char| c.is_whitespace() || c == '[' || c == ']' || c == ',')
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| {
            w.trim_end_matches(|c: char| !c.is_alphanumeric())
                .to_string()
        })
        .collect()
}

#[test]
fn both_command_summaries_list_every_subcommand_and_option() {
    let top = help(&["--help"]);
    let commands: BTreeSet<String> = section(&top, "Commands:")
        .into_iter()
        .filter(|c| c != "help")
        .collect();
    assert!(
        commands.contains("run") && commands.contains("derive"),
        "{top}"
    );

    let readme = read("../README.md");
    let root = block(&readme, "## The `dth` command", "text");
    let in_root: BTreeSet<String> = root
        .iter()
        .filter_map(|l| l.strip_prefix("cargo run --release -- "))
        .filter_map(|rest| rest.split_whitespace().next())
        .filter(|w| !w.starts_with('-') && *w != "help")
        .map(str::to_string)
        .collect();
    assert_eq!(
        in_root, commands,
        "README.md's command summary vs `dth --help`"
    );

    let examples = read("README.md");
    let summary = block(&examples, "# dth-examples", "text");
    let in_examples: BTreeSet<String> = summary
        .iter()
        .filter_map(|l| l.strip_prefix("dth "))
        .filter(|rest| !rest.starts_with(' '))
        .filter_map(|rest| rest.split_whitespace().next())
        .filter(|w| !w.starts_with('-'))
        .map(str::to_string)
        .collect();
    assert_eq!(
        in_examples, commands,
        "dth-examples/README.md's command summary vs `dth --help`"
    );

    // Every option of every command is in the detailed summary.
    let documented = long_options(&summary.join("\n"));
    let mut options = long_options(&top);
    for c in &commands {
        options.extend(long_options(&help(&[c.as_str(), "--help"])));
    }
    for o in ["--help", "--version"] {
        options.remove(o);
    }
    let missing: Vec<_> = options.difference(&documented).collect();
    assert!(
        missing.is_empty(),
        "options `dth help` lists that dth-examples/README.md's summary does not: {missing:?}"
    );
}

/// `name`s in backticks in `cell`.
fn ticked(cell: &str) -> BTreeSet<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The parameter names of a `params: a = 1 (what, > 0), b = 2 (...)` line of `dth list`.
fn param_names(line: &str) -> BTreeSet<String> {
    line.trim()
        .trim_start_matches("params:")
        .split(", ")
        .filter_map(|piece| piece.trim().split_once(" = "))
        .map(|(name, _)| name.to_string())
        .filter(|n| n.chars().all(|c| c.is_alphanumeric() || c == '_'))
        .collect()
}

#[test]
fn the_catalogue_and_scene_reference_name_what_dth_list_prints() {
    let list = help(&["list"]);
    // Systems and their parameters, as `dth list` prints them.
    let mut systems = Vec::new();
    let mut lines = list
        .lines()
        .skip_while(|l| l.trim_end() != "Systems:")
        .skip(1);
    while let Some(l) = lines.next() {
        if l.trim().is_empty() {
            break;
        }
        if l.starts_with("  ") && !l.starts_with("   ") {
            let name = l.split_whitespace().next().unwrap_or_default().to_string();
            let params = lines
                .by_ref()
                .find(|p| p.trim_start().starts_with("params:"))
                .map(param_names)
                .unwrap_or_default();
            systems.push((name, params));
        }
    }
    assert!(systems.len() >= 9, "{list}");

    let examples = read("README.md");
    let table = &examples[examples
        .find("## The catalogue")
        .expect("catalogue section")..];
    let rows: Vec<(BTreeSet<String>, BTreeSet<String>)> = table
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            let cells: Vec<&str> = l.split(" | ").collect();
            (
                ticked(cells[0]),
                ticked(cells.get(2).copied().unwrap_or("")),
            )
        })
        .collect();
    let tabled: BTreeSet<String> = rows.iter().flat_map(|(n, _)| n.clone()).collect();
    let listed: BTreeSet<String> = systems.iter().map(|(n, _)| n.clone()).collect();
    assert_eq!(
        tabled, listed,
        "the catalogue table's systems vs `dth list`"
    );
    for (name, params) in &systems {
        let (_, in_table) = rows
            .iter()
            .find(|(names, _)| names.contains(name))
            .expect("listed above");
        assert_eq!(
            in_table, params,
            "parameters of `{name}` in the catalogue table"
        );
    }

    // The scene reference names every system, method and effect.
    let scene = block(&examples, "## Scene files", "toml").join("\n");
    for (name, _) in &systems {
        assert!(
            scene.contains(name.as_str()),
            "system `{name}` in the scene reference"
        );
    }
    for method in section(&list, "Methods:") {
        assert!(
            scene.contains(method.as_str()),
            "method `{method}` in the scene reference"
        );
    }
    let effects_doc = &examples[examples.find("\nEffects:").expect("the effects paragraph")..];
    for effect in section(&list, "Effects:") {
        assert!(
            effects_doc.contains(&format!("`{effect}`")),
            "effect `{effect}` in the effects paragraph"
        );
    }
}

#[test]
fn the_free_particle_error_shown_is_what_dth_check_prints() {
    let examples = read("README.md");
    let shown = block(&examples, "**Systems without DTH.**", "text").join("\n");
    // A scene with `kind = "dth"` at line 15, as in the README.
    let scene = "# The README's example: dth on the free particle.\n\
                 [system]\n\
                 name = \"free_particle\"\n\
                 \n\
                 [initial]\n\
                 q = [0.0, 0.0]\n\
                 p = [1.0, 0.5]\n\
                 \n\
                 [duration]\n\
                 steps = 10\n\
                 \n\
                 # Psi is identically zero here.\n\
                 \n\
                 [[method]]\n\
                 kind = \"dth\"\n\
                 dtau = 0.1\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("free.toml"), scene).unwrap();
    let o = dth(&["check", "free.toml"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).trim_end(), shown.trim_end());
}

#[test]
fn the_text_hamiltonian_error_shown_is_what_dth_check_prints() {
    let examples = read("README.md");
    let shown = block(&examples, "**Hamiltonians as text.**", "text").join("\n");
    // The README's example: `alpha` written for the parameter `a`.
    let scene = "# The README's example: a Morse oscillator with a misspelt parameter.\n\
                 title = \"Morse oscillator\"\n\
                 \n\
                 [system]\n\
                 title = \"Morse oscillator\"\n\
                 hamiltonian = \"p1^2/(2*m) + d*(1 - exp(-alpha*q1))^2\"\n\
                 params = { m = 1.0, d = 1.0, a = 1.0 }\n\
                 \n\
                 [initial]\n\
                 q = [0.5]\n\
                 p = [0.5]\n\
                 \n\
                 [[method]]\n\
                 kind = \"dth\"\n\
                 dtau = 0.05\n\
                 \n\
                 [duration]\n\
                 steps = 10\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("morse.toml"), scene).unwrap();
    let o = dth(&["check", "morse.toml"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).trim_end(), shown.trim_end());
    // `dth run` refuses it the same way, and writes nothing.
    let o = dth(&["run", "morse.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).trim_end(), shown.trim_end());
    assert!(!dir.path().join("out").exists());
}
