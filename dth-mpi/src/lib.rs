//! The `dth` command across MPI ranks: `mpirun -n K dth-mpi run SCENE.toml` splits an
//! ensemble scene's members over `K` processes (each on its threads), rank 0 gathers the
//! results and writes the same files, byte for byte, as one process; the other ranks write
//! nothing. With the `mpi` feature (an MPI library and libclang for its bindings); without
//! it this crate is empty, so that `cargo test --workspace` needs no MPI.
//!
//! The members go out in chunks on demand (self-scheduling): rank 0 works through chunks like
//! every rank and, between them, a dispatcher on its main thread hands the next chunk to
//! whichever rank asks, so a rank that drew slow members simply asks less often and uneven
//! member costs even out. Results travel as bytes (`dth_examples::ensemble::wire`), every
//! `f64` bit for bit.
#![cfg(feature = "mpi")]

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use indicatif::ProgressBar;
use mpi::environment::{Threading, Universe};
use mpi::point_to_point::MatchedReceiveVec;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use dth_examples::ensemble::member::MemberResult;
use dth_examples::ensemble::schedule::{run_range, set_ranks, Ranks, Work};
use dth_examples::ensemble::wire::{decode, encode};
use dth_examples::Error;

/// Worker to rank 0: results of the last chunk (empty: the first request).
const RESULTS: i32 = 1;
/// Worker to rank 0: a member failed for a reason all members share (the text).
const FAILED: i32 = 2;
/// Rank 0 to worker: the next chunk, or [`STOP`].
const CHUNK: i32 = 3;
const STOP: u64 = u64::MAX;

/// Initialises MPI (threads may run, only the main thread calls MPI) and, with more than one
/// rank, installs [`MpiRanks`] for every ensemble of this process. Keep the universe alive for
/// the whole run: dropping it finalises MPI.
pub fn init() -> Option<Universe> {
    let universe = mpi::initialize_with_threading(Threading::Funneled).map(|(u, _)| u);
    if world().is_some() {
        set_ranks(Box::new(MpiRanks));
    }
    universe
}

/// The MPI ranks of this run: members go out from rank 0 in chunks on demand (see the
/// [crate docs](crate)).
#[derive(Debug, Clone, Copy)]
pub struct MpiRanks;

impl Ranks for MpiRanks {
    fn is_worker(&self) -> bool {
        world().is_some_and(|w| w.rank() != 0)
    }

    fn run(
        &self,
        pool: &rayon::ThreadPool,
        count: usize,
        bar: &ProgressBar,
        work: &Work<'_>,
    ) -> Result<Option<Vec<MemberResult>>, Error> {
        match world() {
            Some(world) => run(&world, pool, count, bar, work),
            None => run_range(pool, 0..count, bar, work).map(Some),
        }
    }
}

/// The world communicator when MPI runs with more than one rank.
fn world() -> Option<SimpleCommunicator> {
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

fn run(
    world: &SimpleCommunicator,
    pool: &rayon::ThreadPool,
    count: usize,
    bar: &ProgressBar,
    work: &Work<'_>,
) -> Result<Option<Vec<MemberResult>>, Error> {
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
