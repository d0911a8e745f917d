//! Results as JSON, CSV and markdown tables; the machine and date they were measured on.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::problem::ProblemInfo;
use super::problems::dth_order;
use super::{Error, Record, ReferenceCheck, Summary};

/// Where and when the results were measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Machine {
    /// CPU model (`/proc/cpuinfo`), or `"unknown"`.
    pub cpu: String,
    /// Hardware threads available to this process.
    pub threads: usize,
    /// Operating system and kernel release.
    pub os: String,
    /// `"release"` or `"dev"` (timings in the dev profile mean little).
    pub profile: &'static str,
    /// Date and time (UTC) at the start of the run, ISO 8601.
    pub date: String,
}

impl Machine {
    /// Describe this machine now.
    pub fn detect() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|m| m.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".to_string());
        let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| s.trim().to_string())
            .unwrap_or_default();
        Machine {
            cpu,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: format!("{} {kernel}", std::env::consts::OS),
            profile: if cfg!(debug_assertions) {
                "dev"
            } else {
                "release"
            },
            date: utc_now(),
        }
    }
}

/// The current UTC time as `YYYY-MM-DDTHH:MM:SSZ` (civil-from-days, H. Hinnant's algorithm).
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

fn write(path: PathBuf, contents: &[u8]) -> Result<PathBuf, Error> {
    std::fs::write(&path, contents).map_err(|source| Error::Io {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}

fn opt(x: Option<f64>) -> String {
    x.map_or(String::new(), |v| format!("{v:e}"))
}

/// Write `workprecision.json`, `workprecision.csv` and `summary.md` into `out`.
pub(crate) fn write_all(summary: &Summary, out: &Path) -> Result<Vec<PathBuf>, Error> {
    // Non-finite numbers (an error that overflowed) as strings, not `null` (`crate::json`).
    let json = crate::json::to_string_pretty(summary)?;
    let mut csv = String::from(
        "system,method,parameter_kind,parameter,steps,mean_dt,time,time_min,timed_runs,global_error,\
         vertex_error,energy_error,vertex_energy_error,invariant_error,vertex_invariant_error,\
         newton_per_step,evaluations_per_step,fallback_steps,failure\n",
    );
    for r in &summary.records {
        let _ = writeln!(
            csv,
            "{},{},{},{:e},{},{:e},{:e},{:e},{},{:e},{},{:e},{},{},{},{},{},{},\"{}\"",
            r.system,
            r.method,
            r.parameter_kind,
            r.parameter,
            r.steps,
            r.mean_dt,
            r.time,
            r.time_min,
            r.timed_runs,
            r.global_error,
            opt(r.vertex_error),
            r.energy_error,
            opt(r.vertex_energy_error),
            opt(r.invariant_error),
            opt(r.vertex_invariant_error),
            opt(r.newton_per_step),
            opt(r.evaluations_per_step),
            r.fallback_steps.map_or(String::new(), |n| n.to_string()),
            r.failure.as_deref().unwrap_or("").replace('"', "'"),
        );
    }
    let m = &summary.machine;
    let md = format!(
        "Measured {} on {} ({} threads, {}), {} profile{}.\n\n{}",
        m.date,
        m.cpu,
        m.threads,
        m.os,
        m.profile,
        if summary.quick { ", quick sweep" } else { "" },
        summary.tables
    );
    Ok(vec![
        write(out.join("workprecision.json"), json.as_bytes())?,
        write(out.join("workprecision.csv"), csv.as_bytes())?,
        write(out.join("summary.md"), md.as_bytes())?,
    ])
}

/// The error of kind `kind` of a record (`"global"`, `"energy"`, `"invariant"`), NaN if absent
/// or failed.
pub(crate) fn error_of(r: &Record, kind: &str) -> f64 {
    if r.failure.is_some() {
        return f64::NAN;
    }
    match kind {
        "global" => r.global_error,
        "energy" => r.energy_error,
        "invariant" => r.invariant_error.unwrap_or(f64::NAN),
        _ => f64::NAN,
    }
}

/// The cheapest run of `method` on `system` whose error of `kind` is at most `target`.
fn cheapest<'a>(
    records: &'a [Record],
    system: &str,
    method: &str,
    kind: &str,
    target: f64,
) -> Option<&'a Record> {
    records
        .iter()
        .filter(|r| r.system == system && r.method == method)
        .filter(|r| error_of(r, kind) <= target && r.time.is_finite())
        .min_by(|a, b| a.time.total_cmp(&b.time))
}

fn methods_of<'a>(records: &'a [Record], system: &str) -> Vec<&'a str> {
    let mut v: Vec<&str> = Vec::new();
    for r in records.iter().filter(|r| r.system == system) {
        if !v.contains(&r.method) {
            v.push(r.method);
        }
    }
    v
}

/// A global-error target is measurable when it is at least 100 times the reference solution's
/// own estimated error; energy and invariant errors need no reference.
fn measurable(kind: &str, target: f64, reference: f64) -> bool {
    kind != "global" || target >= 100.0 * reference
}

fn is_dth(method: &str) -> bool {
    dth_order(method).is_some()
}

/// Classical order of a method by its recorded name.
fn order(method: &str) -> u32 {
    dth_order(method).unwrap_or(if method.starts_with("dop853") {
        8
    } else if method.starts_with("rk4") || method.starts_with("gauss_legendre2") {
        4
    } else {
        2
    })
}

fn seconds(t: f64) -> String {
    if t >= 1.0 {
        format!("{t:.2} s")
    } else if t >= 1e-3 {
        format!("{:.2} ms", t * 1e3)
    } else {
        format!("{:.1} us", t * 1e6)
    }
}

/// The targets of the headline table: `(kind, target)`.
pub(crate) const TARGETS: [(&str, f64); 5] = [
    ("global", 1e-3),
    ("global", 1e-6),
    ("global", 1e-9),
    ("global", 1e-12),
    ("energy", 1e-13),
];

/// The global-error targets of the high-order table.
const HIGH_ORDER_TARGETS: [f64; 3] = [1e-6, 1e-9, 1e-12];

/// The fourth- and eighth-order references of the high-order table.
const HIGH_ORDER_PEERS: [&str; 2] = ["gauss_legendre2", "dop853"];

/// The DTH methods of the high-order table on `system`: of each order 2, 4, 6, 8, the first
/// recorded method of that order with a successful run (`dth_joint`, `dth4`, `dth6`, `dth8`
/// where plain DTH runs through; `dth_robust`, `dth8_robust` where it breaks down).
fn high_order_dth<'a>(records: &'a [Record], system: &str) -> Vec<&'a str> {
    [2, 4, 6, 8]
        .into_iter()
        .filter_map(|order| {
            records
                .iter()
                .filter(|r| r.system == system && r.failure.is_none())
                .find(|r| dth_order(r.method) == Some(order))
                .map(|r| r.method)
        })
        .collect()
}

/// Markdown: per problem, the cost of each DTH order, Gauss-Legendre 2 and DOP853 at global
/// errors 1e-6, 1e-9, 1e-12 (with the energy error of that run), and the highest DTH order's
/// time relative to the other two. A target below 100 times the reference solution's own
/// estimated error is not measurable there and is left out.
fn high_order_table(s: &mut String, records: &[Record], info: &ProblemInfo, reference: f64) {
    let system = info.name;
    let dth = high_order_dth(records, system);
    let Some(&top) = dth.last() else {
        return;
    };
    let methods: Vec<&str> = dth.iter().copied().chain(HIGH_ORDER_PEERS).collect();
    let _ = writeln!(
        s,
        "\nDTH of order 2-8 against Gauss-Legendre 2 and DOP853: cheapest time to each global \
         error, with the max energy error of that run:\n"
    );
    let mut header = "| target |".to_string();
    let mut rule = "|---|".to_string();
    for m in &methods {
        let _ = write!(header, " {m} |");
        rule.push_str("---|");
    }
    let _ = writeln!(
        s,
        "{header} {top} / dop853 | {top} / gauss_legendre2 |\n{rule}---|---|"
    );
    for target in HIGH_ORDER_TARGETS {
        if !measurable("global", target, reference) {
            let _ = writeln!(
                s,
                "| global <= {target:.0e} | (not measurable: reference error {reference:.0e}) |"
            );
            continue;
        }
        let best = |m: &str| cheapest(records, system, m, "global", target);
        let mut row = format!("| global <= {target:.0e} |");
        for m in &methods {
            let cell = best(m).map_or("-".to_string(), |r| {
                format!("{} (E {:.0e})", seconds(r.time), r.energy_error)
            });
            let _ = write!(row, " {cell} |");
        }
        let ratio = |other: &str| match (best(top), best(other)) {
            (Some(a), Some(b)) => format!("{:.2}", a.time / b.time),
            _ => "-".to_string(),
        };
        let _ = writeln!(row, " {} | {} |", ratio("dop853"), ratio("gauss_legendre2"));
        s.push_str(&row);
    }
}

/// Markdown: the share of fallback steps of each DTH method that took any (robust mode), over
/// its successful runs: nothing where no method fell back.
fn fallback_line(s: &mut String, records: &[Record], system: &str, methods: &[&str]) {
    let mut parts = Vec::new();
    for m in methods {
        let shares: Vec<f64> = records
            .iter()
            .filter(|r| r.system == system && r.method == *m && r.failure.is_none())
            .filter_map(|r| Some(r.fallback_steps? as f64 / r.steps.max(1) as f64))
            .collect();
        if shares.iter().any(|x| *x > 0.0) {
            let lo = shares.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = shares.iter().copied().fold(0.0, f64::max);
            parts.push(format!("`{m}` {:.1}-{:.1}%", 100.0 * lo, 100.0 * hi));
        }
    }
    if !parts.is_empty() {
        let _ = writeln!(
            s,
            "\nRobust mode: share of steps taken as fallback steps (energy-conserving \
             discrete-gradient steps where DTH has no positive root), over the sweep: {}.",
            parts.join(", ")
        );
    }
}

/// Markdown: per problem, the headline table (cheapest method per target, DTH relative to it)
/// and the matrix of every method's cheapest time per target with its Newton iterations.
pub(crate) fn tables(
    records: &[Record],
    infos: &[ProblemInfo],
    references: &[ReferenceCheck],
) -> String {
    let mut s = String::new();
    for info in infos {
        let system = info.name;
        let methods = methods_of(records, system);
        let reference = references
            .iter()
            .find(|r| r.system == system)
            .map_or(0.0, |r| r.estimated_error);
        let _ = writeln!(
            s,
            "#### {} (`{system}`, T = {:.4}, {} periods)\n",
            info.title,
            info.t_end,
            (info.t_end / info.period).round()
        );
        let _ = writeln!(
            s,
            "| target | cheapest method | its time | cheapest 2nd-order peer | its time | best DTH | DTH time | DTH / cheapest | DTH / 2nd-order peer |\n\
             |---|---|---|---|---|---|---|---|---|"
        );
        let fastest = |filter: &dyn Fn(&str) -> bool, kind: &str, target: f64| {
            methods
                .iter()
                .filter(|m| filter(m))
                .filter_map(|m| cheapest(records, system, m, kind, target))
                .min_by(|a, b| a.time.total_cmp(&b.time))
        };
        let describe = |r: Option<&Record>| {
            r.map_or(("not reached".to_string(), "-".to_string()), |r| {
                (
                    format!("{} ({} {:.3e})", r.method, r.parameter_kind, r.parameter),
                    seconds(r.time),
                )
            })
        };
        let ratio = |a: Option<&Record>, b: Option<&Record>| match (a, b) {
            (Some(a), Some(b)) => format!("{:.2}", a.time / b.time),
            _ => "-".to_string(),
        };
        for (kind, target) in TARGETS {
            if !measurable(kind, target, reference) {
                continue;
            }
            let best = fastest(&|_| true, kind, target);
            let second = fastest(&|m| !is_dth(m) && order(m) == 2, kind, target);
            let dth = fastest(&is_dth, kind, target);
            let label = format!("{kind} <= {target:.0e}");
            let (bm, bt) = describe(best);
            let (sm, st) = describe(second);
            let (dm, dt) = match dth {
                Some(d) => (d.method.to_string(), seconds(d.time)),
                None => {
                    let best_dth = records
                        .iter()
                        .filter(|r| r.system == system && is_dth(r.method))
                        .map(|r| error_of(r, kind))
                        .filter(|e| e.is_finite())
                        .fold(f64::INFINITY, f64::min);
                    (
                        format!("not reached (best {best_dth:.1e})"),
                        "-".to_string(),
                    )
                }
            };
            let _ = writeln!(
                s,
                "| {label} | {bm} | {bt} | {sm} | {st} | {dm} | {dt} | {} | {} |",
                ratio(dth, best),
                ratio(dth, second)
            );
        }
        let _ = writeln!(
            s,
            "\nCheapest time per method to reach each target (`-`: not reached in the sweep; \
             `n/m`: below 100 times the reference solution's error); Newton iterations per \
             step over the sweep (nested DTH: LU factorizations; DTH 4-8: all sub-steps):\n"
        );
        let _ = writeln!(
            s,
            "| method | err <= 1e-3 | err <= 1e-6 | err <= 1e-9 | err <= 1e-12 | energy <= 1e-13 | Newton/step | failures |\n\
             |---|---|---|---|---|---|---|---|"
        );
        for m in &methods {
            let mut row = format!("| {m} |");
            for (kind, target) in TARGETS {
                let cell = if measurable(kind, target, reference) {
                    cheapest(records, system, m, kind, target)
                        .map_or("-".to_string(), |r| seconds(r.time))
                } else {
                    "n/m".to_string()
                };
                let _ = write!(row, " {cell} |");
            }
            let newton: Vec<f64> = records
                .iter()
                .filter(|r| r.system == system && r.method == *m && r.failure.is_none())
                .filter_map(|r| r.newton_per_step)
                .collect();
            let newton = if newton.is_empty() {
                "-".to_string()
            } else {
                let lo = newton.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = newton.iter().copied().fold(0.0, f64::max);
                format!("{lo:.2}-{hi:.2}")
            };
            let failures = records
                .iter()
                .filter(|r| r.system == system && r.method == *m && r.failure.is_some())
                .count();
            let _ = writeln!(row, " {newton} | {failures} |");
            s.push_str(&row);
        }
        fallback_line(&mut s, records, system, &methods);
        high_order_table(&mut s, records, info, reference);
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::workprecision::runners::blank;

    /// The high-order table takes, of each order, the first DTH method with a successful run:
    /// the robust variants where plain DTH failed everywhere.
    #[test]
    fn high_order_table_takes_the_dth_methods_that_ran() {
        let record = |system, method, failed: bool| {
            let mut r = blank(system, method, "dtau", 0.1);
            if failed {
                r.failure = Some("breakdown".to_string());
            }
            r
        };
        let records = [
            record("plain", "dth_joint", false),
            record("plain", "dth_nested", false),
            record("plain", "dth4", true),
            record("plain", "dth4", false),
            record("plain", "dth6", false),
            record("plain", "dth8", false),
            record("robust", "dth_joint", true),
            record("robust", "dth8", true),
            record("robust", "dth_robust", false),
            record("robust", "dth8_robust", false),
            record("robust", "dop853", false),
        ];
        assert_eq!(
            high_order_dth(&records, "plain"),
            ["dth_joint", "dth4", "dth6", "dth8"]
        );
        assert_eq!(
            high_order_dth(&records, "robust"),
            ["dth_robust", "dth8_robust"]
        );
    }

    /// The fallback line appears where a method fell back, with its share of steps.
    #[test]
    fn fallback_share_is_reported_where_there_is_one() {
        let mut robust = blank("robust", "dth_robust", "dtau", 0.1);
        (robust.steps, robust.fallback_steps) = (200, Some(15));
        let mut plain = blank("robust", "dth_joint", "dtau", 0.1);
        (plain.steps, plain.fallback_steps) = (200, Some(0));
        let records = [robust, plain];
        let mut s = String::new();
        fallback_line(&mut s, &records, "robust", &["dth_joint", "dth_robust"]);
        assert!(s.contains("`dth_robust` 7.5-7.5%"), "{s}");
        assert!(!s.contains("dth_joint"), "{s}");
        let mut none = String::new();
        fallback_line(&mut none, &records[1..], "robust", &["dth_joint"]);
        assert!(none.is_empty(), "{none}");
    }

    #[test]
    fn utc_date_is_well_formed() {
        let d = utc_now();
        assert_eq!(d.len(), 20, "{d}");
        assert!(d.starts_with("20") && d.ends_with('Z'));
    }
}
