//! Who runs which member: rayon over the members on every core of this process, and, with
//! the `mpi` feature under `mpirun -n K`, the members split across `K` ranks.
//!
//! Results are gathered by member number, whatever thread or rank computed them, so the files
//! are the same bytes for any thread count and any number of ranks: each member's run depends
//! on nothing but its own state (no shared accumulator, no reduction in thread order).
//!
//! Across ranks the members go out in chunks on demand (self-scheduling): rank 0 works
//! through chunks like every rank and, between them, a dispatcher on its main thread hands the
//! next chunk to whichever rank asks, so a rank that drew slow members simply asks less often
//! and uneven member costs even out. Rank 0 gathers the results and writes the files; the
//! other ranks write nothing.

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

/// Members `range` on `pool`, in order.
fn run_range<F>(
    pool: &rayon::ThreadPool,
    range: std::ops::Range<usize>,
    bar: &ProgressBar,
    work: &F,
) -> Result<Vec<MemberResult>, Error>
where
    F: Fn(usize) -> Result<MemberResult, Error> + Sync,
{
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
/// thousands of them takes seconds to minutes) and, under MPI with more than one rank, across
/// the ranks. Returns the results in member order, or `None` on an MPI rank other than 0
/// (rank 0 has them).
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
    #[cfg(feature = "mpi")]
    if let Some(world) = mpi_ranks::world() {
        return mpi_ranks::run(&world, &pool, count, bar, &work);
    }
    run_range(&pool, 0..count, bar, &work).map(Some)
}

/// `true` in an MPI run on a rank other than 0 (it computes, rank 0 writes). Always `false`
/// without the `mpi` feature.
pub fn is_worker_rank() -> bool {
    #[cfg(feature = "mpi")]
    {
        mpi_ranks::world().is_some_and(|w| mpi::traits::Communicator::rank(&w) != 0)
    }
    #[cfg(not(feature = "mpi"))]
    {
        false
    }
}

#[cfg(feature = "mpi")]
pub use mpi_ranks::init as init_mpi;

#[cfg(feature = "mpi")]
mod mpi_ranks {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;

    use indicatif::ProgressBar;
    use mpi::environment::{Threading, Universe};
    use mpi::point_to_point::MatchedReceiveVec;
    use mpi::topology::SimpleCommunicator;
    use mpi::traits::*;

    use super::super::member::MemberResult;
    use super::super::wire::{decode, encode};
    use super::run_range;
    use crate::error::Error;

    /// Worker to rank 0: results of the last chunk (empty: the first request).
    const RESULTS: i32 = 1;
    /// Worker to rank 0: a member failed for a reason all members share (the text).
    const FAILED: i32 = 2;
    /// Rank 0 to worker: the next chunk, or [`STOP`].
    const CHUNK: i32 = 3;
    const STOP: u64 = u64::MAX;

    /// Initialises MPI (threads may run, only the main thread calls MPI). Keep the universe
    /// alive for the whole run: dropping it finalises MPI.
    pub fn init() -> Option<Universe> {
        mpi::initialize_with_threading(Threading::Funneled).map(|(u, _)| u)
    }

    /// The world communicator when MPI runs with more than one rank.
    pub(super) fn world() -> Option<SimpleCommunicator> {
        if !mpi::environment::is_initialized() || mpi::environment::is_finalized() {
            return None;
        }
        let w = SimpleCommunicator::world();
        (w.size() > 1).then_some(w)
    }

    fn failed(rank: i32, reason: String) -> Error {
        Error::NotAvailable {
            what: "ensemble member on MPI rank",
            name: rank.to_string(),
            reason,
        }
    }

    pub(super) fn run<F>(
        world: &SimpleCommunicator,
        pool: &rayon::ThreadPool,
        count: usize,
        bar: &ProgressBar,
        work: &F,
    ) -> Result<Option<Vec<MemberResult>>, Error>
    where
        F: Fn(usize) -> Result<MemberResult, Error> + Sync,
    {
        let size = world.size() as usize;
        // About eight chunks a rank: small enough that slow members even out, large enough
        // that a rank's threads share each chunk.
        let chunk = count.div_ceil(8 * size).max(1);
        let chunks = count.div_ceil(chunk);
        let range = |c: usize| c * chunk..((c + 1) * chunk).min(count);
        if world.rank() != 0 {
            let root = world.process_at_rank(0);
            let mut payload = Vec::new();
            loop {
                root.send_with_tag(&payload[..], RESULTS);
                let (reply, _) = root.receive_vec_with_tag::<u64>(CHUNK);
                let c = reply.first().copied().unwrap_or(STOP);
                if c == STOP {
                    return Ok(None);
                }
                match run_range(pool, range(c as usize), &ProgressBar::hidden(), work) {
                    Ok(results) => {
                        payload.clear();
                        encode(&results, &mut payload);
                    }
                    Err(e) => {
                        root.send_with_tag(e.to_string().as_bytes(), FAILED);
                        return Err(e);
                    }
                }
            }
        }
        let next = AtomicUsize::new(0);
        let slots: Mutex<Vec<Option<MemberResult>>> = Mutex::new(vec![None; count]);
        let error: Mutex<Option<Error>> = Mutex::new(None);
        let store = |results: Vec<MemberResult>| {
            let mut slots = slots.lock().unwrap_or_else(|p| p.into_inner());
            for r in results {
                if let Some(slot) = slots.get_mut(r.index) {
                    *slot = Some(r);
                }
            }
        };
        let fail = |e: Error| {
            next.store(chunks, Ordering::SeqCst);
            error
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .get_or_insert(e);
        };
        std::thread::scope(|s| {
            // Rank 0's own share, on its worker threads.
            s.spawn(|| loop {
                let c = next.fetch_add(1, Ordering::SeqCst);
                if c >= chunks {
                    break;
                }
                match run_range(pool, range(c), bar, work) {
                    Ok(results) => store(results),
                    Err(e) => fail(e),
                }
            });
            // The dispatcher: answers every request until each worker has been stopped.
            let mut active = size - 1;
            while active > 0 {
                let Some(probed) = world.any_process().immediate_matched_probe() else {
                    std::thread::sleep(std::time::Duration::from_micros(200));
                    continue;
                };
                let (bytes, status) = probed.matched_receive_vec::<u8>();
                let src = status.source_rank();
                if status.tag() == FAILED {
                    fail(failed(src, String::from_utf8_lossy(&bytes).into_owned()));
                    active -= 1;
                    continue;
                }
                if !bytes.is_empty() {
                    match decode(&bytes) {
                        Some(results) => {
                            bar.inc(results.len() as u64);
                            store(results);
                        }
                        None => fail(failed(src, "its results arrived garbled".into())),
                    }
                }
                let c = next.fetch_add(1, Ordering::SeqCst);
                let reply = if c < chunks { c as u64 } else { STOP };
                if reply == STOP {
                    active -= 1;
                }
                world
                    .process_at_rank(src)
                    .send_with_tag(&[reply][..], CHUNK);
            }
        });
        if let Some(e) = error.into_inner().unwrap_or_else(|p| p.into_inner()) {
            return Err(e);
        }
        let slots = slots.into_inner().unwrap_or_else(|p| p.into_inner());
        let missing = slots.iter().position(Option::is_none);
        match missing {
            Some(i) => Err(failed(0, format!("member {i} never came back"))),
            None => Ok(Some(slots.into_iter().flatten().collect())),
        }
    }
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
