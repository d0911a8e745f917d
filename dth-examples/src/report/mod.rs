//! Reports: what a simulation's results become on disk. CSV series ([`csv`]), the effects'
//! figures ([`figures`]), the thesis's Table 4.1 ([`table41`]) and Figures 4.1-4.15
//! ([`thesis`]), and the static `index.html` ([`html`]); [`RunReport`] is `summary.json`.
//!
//! Layers: `html` reads a [`RunReport`]; `csv`, `figures` and `thesis` read simulation results
//! (`crate::simulate`); nothing here is imported from below.

pub mod csv;
pub mod figures;
pub mod html;
pub mod npy;
pub mod table41;
pub mod thesis;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::effects::Deviation;
use crate::error::Error;
use crate::simulate::MethodSummary;

/// What a run produced (`summary.json` is this, serialized).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// Scene title.
    pub title: String,
    /// System name.
    pub system: String,
    /// Parameters used.
    pub params: BTreeMap<String, f64>,
    /// Where the output is (empty when computed without writing).
    pub out: PathBuf,
    /// Per method.
    pub methods: Vec<MethodSummary>,
    /// Files written, relative to `out`.
    pub files: Vec<String>,
    /// Table 4.1 (scenes with `thesis_figures = true`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table41: Option<table41::Table>,
    /// The thesis's figures (scenes with `thesis_figures = true`), in its order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub thesis_figures: Vec<thesis::ThesisFigure>,
    /// Why the thesis's figures were not drawn, when one of their runs failed (a scene with
    /// `thesis_figures = true` whose method fails: the rest of the output is written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thesis_figures_failure: Option<String>,
    /// What an ensemble scene ran (`crate::ensemble`), counted; `None` for a single run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ensemble: Option<EnsembleCounts>,
    /// Where the run was interrupted (SIGINT or SIGTERM; `RunOptions::interrupt`), when it
    /// was: what it computed up to there is written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interrupted: Option<Interrupted>,
}

/// Where a run was interrupted (`summary.json`'s `interrupted`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interrupted {
    /// The method that was running, by label; `None` when none was (the interruption came
    /// during the thesis's figures, or during an ensemble: its table marks the members that
    /// were interrupted or not run).
    pub method: Option<String>,
    /// The step the method stopped before (every state before it is in the output).
    pub step: Option<usize>,
    /// The time of the last state the method reached.
    pub t: Option<f64>,
    /// The scene's methods that did not run, by label.
    pub not_run: Vec<String>,
    /// What was being computed when no method was running: "the thesis's figures" (not
    /// drawn), "the ensemble's members" (the table marks the ones interrupted or not run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub during: Option<String>,
}

/// "interrupted before step 3 of method `a` (last state at t = 0.3); not run: b".
impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted")?;
        if let Some(during) = &self.during {
            write!(f, " during {during}")?;
        }
        if let (Some(method), Some(step)) = (&self.method, self.step) {
            write!(f, " before step {step} of method `{method}`")?;
            if let Some(t) = self.t {
                write!(f, " (last state at t = {t})")?;
            }
        }
        if !self.not_run.is_empty() {
            write!(f, "; not run: {}", self.not_run.join(", "))?;
        }
        Ok(())
    }
}

/// What an ensemble scene ran (`crate::ensemble`), counted (in `summary.json` and
/// `ensemble.json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct EnsembleCounts {
    /// Members the sampler drew.
    pub drawn: usize,
    /// Members the energy shell skipped (no real solution).
    pub skipped: usize,
    /// Members whose parameters or state made no run (recorded with a failure).
    pub not_run: usize,
    /// Member runs (member and method) that failed mid-run.
    pub failed_runs: usize,
    /// Member runs that took fallback steps (robust DTH; `fallback_steps` in the table).
    pub fallback_runs: usize,
    /// A chaos map's verdicts against half the step (`crate::ensemble::step_check`), when
    /// the ensemble asks for MEGNO and was not interrupted.
    pub step_check: Option<StepCheck>,
}

impl EnsembleCounts {
    /// ", 3 method runs took fallback steps (robust mode)" when any did, for the command's
    /// line and `index.html`; empty otherwise.
    pub fn fallback_note(&self) -> String {
        match self.fallback_runs {
            0 => String::new(),
            n => format!(", {n} method runs took fallback steps (robust mode)"),
        }
    }

    /// [`StepCheck::note`] when the check ran; empty otherwise.
    pub fn step_check_note(&self) -> String {
        self.step_check.map(|c| c.note()).unwrap_or_default()
    }
}

/// A chaos map's verdicts checked against half the step (`crate::ensemble::step_check`),
/// counted over (member, method) runs that have a verdict at both
/// steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct StepCheck {
    /// Sampled runs compared.
    pub compared: usize,
    /// Of them, runs whose verdict changed at half the step.
    pub changed: usize,
}

impl StepCheck {
    /// ", verdict changed at half the step for 2 of 32 sampled runs: halve the step" when any
    /// changed, ", verdicts unchanged at half the step (32 sampled runs)" otherwise.
    pub fn note(&self) -> String {
        match self.changed {
            0 => format!(
                ", MEGNO verdicts unchanged at half the step ({} sampled runs)",
                self.compared
            ),
            n => format!(
                ", warning: the MEGNO verdict changed at half the step for {n} of {} sampled runs (the map depends on the step: halve it)",
                self.compared
            ),
        }
    }
}

impl RunReport {
    /// Mean and max deviations of every method as a markdown table (empty when no method
    /// has statistics, i.e. no `energy_deviation`, `invariants` or `comparison_table`).
    pub fn deviation_markdown(&self) -> String {
        let mut s = String::new();
        for m in &self.methods {
            for d in m.energy.iter().chain(&m.invariants) {
                if s.is_empty() {
                    s.push_str("| method | quantity | mean | max | vertices mean | vertices max |\n|---|---|---:|---:|---:|---:|\n");
                }
                let sci = |x: f64| format!("{x:.3e}");
                let (mean, max) = deviation_cells(Some(d.points), sci);
                let (vm, vx) = deviation_cells(d.vertices, sci);
                let _ = writeln!(
                    s,
                    "| {} | {} | {mean} | {max} | {vm} | {vx} |",
                    m.label, d.name
                );
            }
        }
        s
    }

    /// "fallback steps: dth 1517 of 1621 steps (93.6%), 97.2% of the physical time" for the
    /// methods that can fall back or did (`MethodSummary::reports_fallback`), for the
    /// command's summary line; `None` when there is none.
    pub fn fallback_summary(&self) -> Option<String> {
        let parts: Vec<String> = self
            .methods
            .iter()
            .filter(|m| m.reports_fallback())
            .map(|m| format!("{} {}", m.label, m.fallback))
            .collect();
        (!parts.is_empty()).then(|| format!("fallback steps: {}", parts.join("; ")))
    }

    /// "events: dth stopped by `close` at t = 2.7531; midpoint: 3 recorded" for the methods
    /// whose runs an event fired in, for the command's summary line; `None` when none did.
    pub fn events_summary(&self) -> Option<String> {
        let parts: Vec<String> = self
            .methods
            .iter()
            .filter(|m| !m.events.is_empty())
            .map(|m| match m.stopped_by() {
                Some(e) => format!("{} stopped by `{}` at t = {}", m.label, e.name, e.t),
                None => format!("{}: {} recorded", m.label, m.events.len()),
            })
            .collect();
        (!parts.is_empty()).then(|| format!("events: {}", parts.join("; ")))
    }

    /// The warnings about methods with more than `fallback::WARN_ABOVE` of their steps
    /// fallen back (`Fallback::warning`).
    pub fn fallback_warnings(&self) -> impl Iterator<Item = String> + '_ {
        self.methods
            .iter()
            .filter_map(|m| m.fallback.warning(&m.label))
    }

    /// The methods that failed mid-run.
    pub fn failures(&self) -> impl Iterator<Item = &MethodSummary> {
        self.methods.iter().filter(|m| m.failure.is_some())
    }

    /// `true` when the run computed everything the scene asked for: no method failed, the
    /// thesis's figures (if asked for) were drawn, and it was not interrupted.
    pub fn complete(&self) -> bool {
        self.failures().next().is_none()
            && self.thesis_figures_failure.is_none()
            && self.interrupted.is_none()
    }
}

/// The mean and max cells of a deviation in a table, formatted by `format`; `-` where there is
/// nothing to show (no vertices, or no state after the first: `Deviation::observed`).
pub fn deviation_cells(d: Option<Deviation>, format: impl Fn(f64) -> String) -> (String, String) {
    d.and_then(|d| d.observed())
        .map_or(("-".to_string(), "-".to_string()), |(mean, max)| {
            (format(mean), format(max))
        })
}

/// Writes `contents` to `path`.
pub fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), Error> {
    std::fs::write(path, contents).map_err(|source| Error::Io {
        what: "cannot write",
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `value` as pretty JSON to `path`, a non-finite number as a string (see
/// [`crate::json`]).
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<(), Error> {
    let json = crate::json::to_string_pretty(value).map_err(|e| Error::Io {
        what: "cannot serialize",
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    write_file(path, json)
}
