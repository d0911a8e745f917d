//! `dth-mpi`: the `dth` command (`dth_examples::cli`) with ensembles split across MPI ranks.

fn main() -> std::process::ExitCode {
    // MPI lives until `main` ends (dropping the universe finalises it).
    let _universe = dth_mpi::init();
    dth_examples::cli::main()
}
