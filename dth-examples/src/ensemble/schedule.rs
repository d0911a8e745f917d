//! Who runs which member: rayon over the members on every core of this process, and, when a
//! distributed run installed its [`Ranks`] (the `dth-mpi` command under `mpirun -n K`), the
//! members split across `K` ranks.
//!
//! Results are gathered by member number, whatever thread or rank computed them, so the files
//! are the same bytes for any thread count and any number of ranks: each member's run depends
//! on nothing but its own state (no shared accumulator, no reduction in thread order). How
//! MPI's ranks share the members out is `dth-mpi`'s (its crate docs); the first rank writes
//! the files, the others nothing ([`is_worker_rank`]).

use std::sync::OnceLock;

use indicatif::ProgressBar;
use rayon::prelude::*;

use super::member::MemberResult;
use crate::error::Error;

/// The worker pool: `threads` threads, or one per core (`None`).
fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::NotAvailable {
            what: "thread pool of",
            name: format!("{} threads", threads.unwrap_or(0)),
            reason: e.to_string(),
        })
}

/// The work of one member: its number in, its result out.
pub type Work<'a> = dyn Fn(usize) -> Result<MemberResult, Error> + Sync + 'a;

/// The ranks of a distributed run (MPI's, in the `dth-mpi` crate): installed once with
/// [`set_ranks`], then [`run_members`] hands every ensemble to it.
pub trait Ranks: Send + Sync {
    /// `true` on a rank that computes but does not write (every rank but the first).
    fn is_worker(&self) -> bool;

    /// Runs members `0..count` across the ranks, this rank's share on `pool` (with
    /// [`run_range`]): the results in member order on the first rank, `None` on the others.
    ///
    /// # Errors
    /// The first member's error, on any rank.
    fn run(
        &self,
        pool: &rayon::ThreadPool,
        count: usize,
        bar: &ProgressBar,
        work: &Work<'_>,
    ) -> Result<Option<Vec<MemberResult>>, Error>;
}

static RANKS: OnceLock<Box<dyn Ranks>> = OnceLock::new();

/// Installs the ranks every ensemble of this process runs across; `false` (and nothing
/// changes) when some were installed before.
pub fn set_ranks(ranks: Box<dyn Ranks>) -> bool {
    RANKS.set(ranks).is_ok()
}

/// Members `range` on `pool`, in order, each counted on `bar` when done.
///
/// # Errors
/// The first error of a member.
pub fn run_range(
    pool: &rayon::ThreadPool,
    range: std::ops::Range<usize>,
    bar: &ProgressBar,
    work: &Work<'_>,
) -> Result<Vec<MemberResult>, Error> {
    pool.install(|| {
        range
            .into_par_iter()
            .map(|i| {
                let r = work(i);
                bar.inc(1);
                r
            })
            .collect()
    })
}

/// Runs members `0..count` with `work`, on `threads` threads (`None`: all cores; never more
/// than `count`, as a thread beyond one per member would have nothing to do and starting
/// thousands of them takes seconds to minutes) and, when [`Ranks`] are installed, across
/// them. Returns the results in member order, or `None` on a worker rank (the first rank has
/// them).
pub fn run_members<F>(
    count: usize,
    threads: Option<usize>,
    bar: &ProgressBar,
    work: F,
) -> Result<Option<Vec<MemberResult>>, Error>
where
    F: Fn(usize) -> Result<MemberResult, Error> + Sync,
{
    let pool = pool(threads.map(|t| t.min(count).max(1)))?;
    if let Some(ranks) = RANKS.get() {
        return ranks.run(&pool, count, bar, &work);
    }
    run_range(&pool, 0..count, bar, &work).map(Some)
}

/// `true` in a distributed run on a rank other than the first (it computes, the first
/// writes); `false` without installed [`Ranks`].
pub fn is_worker_rank() -> bool {
    RANKS.get().is_some_and(|r| r.is_worker())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--threads 65535` on a three-member ensemble started 65535 threads (minutes of thread
    /// creation before the first member ran): the pool now has one thread per member at most.
    #[test]
    fn no_more_threads_than_members() {
        let bar = ProgressBar::hidden();
        let seen = std::sync::Mutex::new(Vec::new());
        let results = run_members(3, Some(65_535), &bar, |index| {
            if let Ok(mut s) = seen.lock() {
                s.push(rayon::current_num_threads());
            }
            Ok(MemberResult {
                index,
                params: Default::default(),
                start: None,
                not_run: None,
                skipped: false,
                runs: Vec::new(),
            })
        });
        let indices: Vec<usize> = results
            .ok()
            .flatten()
            .unwrap_or_default()
            .iter()
            .map(|r| r.index)
            .collect();
        assert_eq!(indices, [0, 1, 2]);
        assert_eq!(seen.into_inner().ok(), Some(vec![3, 3, 3]));
    }
}
