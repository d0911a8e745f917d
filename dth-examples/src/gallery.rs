//! The documentation's figure gallery (`dth gallery`). A manifest (`docs/gallery.toml`) names,
//! for each figure, what draws it (a committed scene, or a problem of the work-precision
//! benchmark), the figure's stem in that run's output, a title and a caption. The command runs
//! each scene and problem once (their whole output, SVGs included, is kept under
//! `dth-out/gallery/`), copies every named figure's PNG into `figures/` beside the manifest
//! (an SVG of a section with 40,000 points is megabytes: not for a repository), and writes
//! `gallery.md` there from the captions: the gallery is what the scenes draw today, and a
//! figure without a scene cannot be listed.
//!
//! ```
//! let manifest = dth_examples::gallery::Manifest::parse(
//!     r#"
//!     [[figure]]
//!     name = "fput_recurrence"
//!     scene = "../dth-examples/scenes/fput.toml"
//!     draws = "normal_modes_dth"
//!     title = "The FPUT recurrence"
//!     caption = "Mode 1's energy returns."
//!     "#,
//!     "gallery.toml",
//! )
//! .unwrap();
//! assert_eq!(manifest.figures[0].name, "fput_recurrence");
//! assert!(manifest.markdown().contains("![The FPUT recurrence](figures/fput_recurrence.png)"));
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::catalogue::Catalogue;
use crate::output::Staging;
use crate::simulate::RunOptions;
use crate::workprecision::{self, WorkPrecisionOptions};

/// What building the gallery can fail with, naming the manifest entry or file.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The manifest could not be read.
    #[error("cannot read the gallery manifest `{path}`")]
    Unreadable {
        /// The manifest.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The manifest is not valid TOML of the expected form.
    #[error("{file}: {message}")]
    Invalid {
        /// The manifest's name.
        file: String,
        /// What is wrong, with its line and column where TOML gives them.
        message: String,
    },
    /// An entry names a scene that is not there.
    #[error("gallery figure `{name}`: scene `{}` does not exist", scene.display())]
    SceneMissing {
        /// The entry.
        name: String,
        /// The scene's path, from the manifest's folder.
        scene: PathBuf,
    },
    /// An entry names a problem the work-precision benchmark does not have.
    #[error("gallery figure `{name}`")]
    Problem {
        /// The entry.
        name: String,
        /// The benchmark's error.
        #[source]
        source: workprecision::Error,
    },
    /// A scene's run failed or could not start.
    #[error("gallery scene `{}`", scene.display())]
    Run {
        /// The scene.
        scene: PathBuf,
        /// The run's error.
        #[source]
        source: Box<crate::RunError>,
    },
    /// The work-precision benchmark failed.
    #[error("gallery: the work-precision benchmark failed")]
    WorkPrecision(#[source] workprecision::Error),
    /// A run did not draw the figure an entry names.
    #[error("gallery figure `{name}`: the run in `{}` drew no `{draws}.png` (its figures: {drawn})", out.display())]
    NotDrawn {
        /// The entry.
        name: String,
        /// The stem it names.
        draws: String,
        /// The run's output folder.
        out: PathBuf,
        /// The figures the run did draw.
        drawn: String,
    },
    /// Writing the gallery failed.
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The output folder of a run could not be staged.
    #[error(transparent)]
    Output(#[from] crate::Error),
}

impl Error {
    /// 2 for a bad manifest (the user's input), 1 for a run or write that failed.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Unreadable { .. }
            | Error::Invalid { .. }
            | Error::SceneMissing { .. }
            | Error::Problem { .. } => 2,
            _ => 1,
        }
    }
}

/// The gallery: its figures in the order the page shows them.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The figures (`[[figure]]` tables).
    #[serde(rename = "figure")]
    pub figures: Vec<Figure>,
}

/// One figure of the gallery (a `[[figure]]` table with exactly one of `scene` and
/// `workprecision`).
#[derive(Debug, Deserialize)]
#[serde(try_from = "RawFigure")]
pub struct Figure {
    /// Its file stem under `figures/` (`[a-z0-9_]`, unique).
    pub name: String,
    /// What draws it ([`Figure::source`]).
    drawn_by: DrawnBy,
    /// The stem of the figure in that run's output folder (`fig4_1`, `poincare1`, ...).
    pub draws: String,
    /// The heading above it.
    pub title: String,
    /// What it shows (markdown).
    pub caption: String,
}

/// A `[[figure]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFigure {
    name: String,
    /// The scene that draws it, from the manifest's folder.
    scene: Option<PathBuf>,
    /// The work-precision problem that draws it (as `dth workprecision --problem NAME`).
    workprecision: Option<String>,
    draws: String,
    title: String,
    caption: String,
}

/// What draws a figure, owned.
#[derive(Debug)]
enum DrawnBy {
    Scene(PathBuf),
    WorkPrecision(String),
}

impl TryFrom<RawFigure> for Figure {
    type Error = String;

    fn try_from(raw: RawFigure) -> Result<Self, String> {
        let drawn_by = match (raw.scene, raw.workprecision) {
            (Some(scene), None) => DrawnBy::Scene(scene),
            (None, Some(problem)) => DrawnBy::WorkPrecision(problem),
            _ => {
                return Err(format!(
                    "figure `{}`: give exactly one of `scene` and `workprecision`",
                    raw.name
                ))
            }
        };
        Ok(Figure {
            name: raw.name,
            drawn_by,
            draws: raw.draws,
            title: raw.title,
            caption: raw.caption,
        })
    }
}

/// What draws a figure.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Source<'a> {
    /// A scene file, from the manifest's folder.
    Scene(&'a Path),
    /// A work-precision problem.
    WorkPrecision(&'a str),
}

impl Figure {
    /// What draws it.
    pub fn source(&self) -> Source<'_> {
        match &self.drawn_by {
            DrawnBy::Scene(scene) => Source::Scene(scene),
            DrawnBy::WorkPrecision(problem) => Source::WorkPrecision(problem),
        }
    }

    /// The command a reader runs to draw it by hand.
    fn command(&self) -> String {
        match self.source() {
            Source::Scene(scene) => format!("cargo run --release -- run {}", from_root(scene)),
            Source::WorkPrecision(p) => {
                format!("cargo run --release -- workprecision --problem {p}")
            }
        }
    }
}

/// A path written from `docs/` as the repository's root sees it.
fn from_root(path: &Path) -> String {
    let s = path.display().to_string();
    s.strip_prefix("../").map(str::to_string).unwrap_or(s)
}

impl Manifest {
    /// Reads and validates the manifest at `path`.
    pub fn read(path: &Path) -> Result<Self, Error> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Unreadable {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses and validates a manifest's text (`file` names it in errors): every figure has
    /// exactly one of `scene` and `workprecision` (`Figure`'s form), and a unique name of
    /// `[a-z0-9_]`.
    pub fn parse(text: &str, file: &str) -> Result<Self, Error> {
        let invalid = |message: String| Error::Invalid {
            file: file.to_string(),
            message,
        };
        let manifest: Manifest = toml::from_str(text).map_err(|e| invalid(e.to_string()))?;
        let mut names = BTreeSet::new();
        for f in &manifest.figures {
            if f.name.is_empty()
                || !f
                    .name
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
            {
                return Err(invalid(format!(
                    "figure name `{}`: expected lowercase letters, digits and `_`",
                    f.name
                )));
            }
            if !names.insert(f.name.as_str()) {
                return Err(invalid(format!("figure `{}` is named twice", f.name)));
            }
        }
        Ok(manifest)
    }

    /// Checks what the figures name, without running anything: every scene exists (from
    /// `dir`, the manifest's folder) and every work-precision problem is one the benchmark has.
    pub fn check(&self, dir: &Path) -> Result<(), Error> {
        for f in &self.figures {
            match f.source() {
                Source::Scene(scene) if !dir.join(scene).is_file() => {
                    return Err(Error::SceneMissing {
                        name: f.name.clone(),
                        scene: scene.to_path_buf(),
                    })
                }
                Source::Scene(_) => {}
                Source::WorkPrecision(p) => {
                    WorkPrecisionOptions::default()
                        .with_problems(&[p])
                        .map_err(|source| Error::Problem {
                            name: f.name.clone(),
                            source,
                        })?;
                }
            }
        }
        Ok(())
    }

    /// `gallery.md`: every figure under its title, with its caption and the command that draws it.
    pub fn markdown(&self) -> String {
        let mut md = String::from(
            "# Gallery\n\n\
             What the `dth` command draws, from the scenes committed in `dth-examples/scenes/`.\n\
             This page and `figures/` are written by one command, from `gallery.toml` beside it\n\
             (edit that file, not this one):\n\n\
             ```sh\ncargo run --release -- gallery\n```\n\n\
             Each figure names the command that draws it by itself; the run's whole output\n\
             (CSV, `summary.json`, `index.html`, every other figure, SVGs) is then in `dth-out/`.\n\
             Figures that need timings on an idle machine (cost against system size) are on the\n\
             [performance page](performance.md), with their commands.\n",
        );
        for f in &self.figures {
            md.push_str(&format!(
                "\n## {}\n\n![{}](figures/{}.png)\n\n{}\n\n",
                f.title,
                f.title,
                f.name,
                f.caption.trim()
            ));
            let source = match f.source() {
                Source::Scene(scene) => {
                    format!("Scene [`{}`]({})", from_root(scene), scene.display())
                }
                Source::WorkPrecision(p) => format!("Work-precision problem `{p}`"),
            };
            md.push_str(&format!(
                "{source}, figure `{}`:\n\n```sh\n{}\n```\n",
                f.draws,
                f.command()
            ));
        }
        md
    }
}

/// What [`build`] wrote.
#[derive(Debug)]
pub struct Built {
    /// The figures copied (PNG), in `figures/` beside the manifest.
    pub files: Vec<PathBuf>,
    /// The gallery page.
    pub page: PathBuf,
}

/// Builds the gallery of the manifest at `path`: runs each scene and problem once into
/// `runs` (a folder per scene, `workprecision/` for the benchmark), copies the figures into
/// `figures/` beside the manifest and writes `gallery.md` there.
pub fn build(path: &Path, runs: &Path, options: &RunOptions) -> Result<Built, Error> {
    let manifest = Manifest::read(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    manifest.check(dir)?;

    // Each scene and the benchmark once; where each figure's run wrote to.
    let mut outputs: BTreeMap<Source<'_>, PathBuf> = BTreeMap::new();
    let problems: BTreeSet<&str> = manifest
        .figures
        .iter()
        .filter_map(|f| match f.source() {
            Source::WorkPrecision(p) => Some(p),
            Source::Scene(_) => None,
        })
        .collect();
    if !problems.is_empty() {
        let options = WorkPrecisionOptions::default()
            .with_problems(&problems.iter().collect::<Vec<_>>())
            .map_err(Error::WorkPrecision)?;
        let staging = Staging::new(&runs.join("workprecision"))?;
        workprecision::run(&options, staging.path()).map_err(Error::WorkPrecision)?;
        let out = staging.commit(true)?;
        for p in problems {
            outputs.insert(Source::WorkPrecision(p), out.clone());
        }
    }
    for f in &manifest.figures {
        let Source::Scene(scene) = f.source() else {
            continue;
        };
        if outputs.contains_key(&Source::Scene(scene)) {
            continue;
        }
        let file = dir.join(scene);
        let stem = scene
            .file_stem()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
        let out = runs.join(stem);
        let failed = |e: crate::RunError| Error::Run {
            scene: file.clone(),
            source: Box::new(e),
        };
        let text = crate::read_scene(&file).map_err(|e| failed(e.into()))?;
        let report = crate::run_scene(
            &text,
            &file.display().to_string(),
            &Catalogue::builtin(),
            &out,
            options,
        )
        .map_err(failed)?;
        outputs.insert(Source::Scene(scene), report.out);
    }

    let figures = dir.join("figures");
    std::fs::create_dir_all(&figures).map_err(|source| Error::Io {
        path: figures.clone(),
        source,
    })?;
    let mut files = Vec::new();
    for f in &manifest.figures {
        let out = &outputs[&f.source()];
        let from = out.join(format!("{}.png", f.draws));
        if !from.is_file() {
            return Err(Error::NotDrawn {
                name: f.name.clone(),
                draws: f.draws.clone(),
                out: out.clone(),
                drawn: drawn(out),
            });
        }
        let to = figures.join(format!("{}.png", f.name));
        std::fs::copy(&from, &to).map_err(|source| Error::Io {
            path: to.clone(),
            source,
        })?;
        files.push(to);
    }
    let page = dir.join("gallery.md");
    std::fs::write(&page, manifest.markdown()).map_err(|source| Error::Io {
        path: page.clone(),
        source,
    })?;
    Ok(Built { files, page })
}

/// The PNG stems in `out`, for an error that names a figure the run did not draw.
fn drawn(out: &Path) -> String {
    let mut stems: Vec<String> = std::fs::read_dir(out)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_suffix(".png").map(str::to_string)
        })
        .collect();
    stems.sort();
    stems.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn docs() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs")
    }

    /// The committed gallery: every figure has a scene that exists (or a problem the
    /// benchmark has), its PNG is in `docs/figures/`, and `docs/gallery.md` is what
    /// the manifest writes (edit the manifest and rerun `dth gallery`, not the page).
    #[test]
    fn the_committed_gallery_is_what_its_manifest_draws() {
        let manifest = match Manifest::read(&docs().join("gallery.toml")) {
            Ok(m) => m,
            Err(e) => panic!("{e}"),
        };
        if let Err(e) = manifest.check(&docs()) {
            panic!("{e}");
        }
        assert!(manifest.figures.len() >= 6, "{manifest:?}");
        for f in &manifest.figures {
            let file = docs().join(format!("figures/{}.png", f.name));
            assert!(
                file.is_file(),
                "{} is missing: run `dth gallery`",
                file.display()
            );
        }
        let page = std::fs::read_to_string(docs().join("gallery.md")).unwrap_or_default();
        assert_eq!(
            page,
            manifest.markdown(),
            "docs/gallery.md differs from what docs/gallery.toml writes: run `dth gallery`"
        );
    }

    #[test]
    fn a_manifest_names_each_figure_once_with_one_source() {
        let entry = |name: &str, source: &str| {
            format!(
                "[[figure]]\nname = \"{name}\"\n{source}\ndraws = \"x\"\ntitle = \"t\"\ncaption = \"c\"\n"
            )
        };
        let scene = "scene = \"a.toml\"";
        let both = "scene = \"a.toml\"\nworkprecision = \"kepler_e09\"";
        for (text, wanted) in [
            (entry("a", scene) + &entry("a", scene), "named twice"),
            (entry("a", both), "exactly one"),
            (
                entry("a", "workprecision = \"kepler_e09\"").replace("draws", "drw"),
                "unknown field",
            ),
            (entry("A b", scene), "lowercase"),
        ] {
            match Manifest::parse(&text, "g.toml") {
                Err(e) => assert!(e.to_string().contains(wanted), "{e}"),
                Ok(_) => panic!("accepted: {text}"),
            }
        }
        let unknown = Manifest::parse(&entry("a", "workprecision = \"kepler\""), "g.toml");
        match unknown.map(|m| m.check(Path::new("."))) {
            Ok(Err(e @ Error::Problem { .. })) => assert_eq!(e.exit_code(), 2),
            other => panic!("{other:?}"),
        }
        let missing = Manifest::parse(&entry("a", "scene = \"nowhere.toml\""), "g.toml");
        match missing.map(|m| m.check(Path::new("."))) {
            Ok(Err(Error::SceneMissing { name, .. })) => assert_eq!(name, "a"),
            other => panic!("{other:?}"),
        }
    }
}
