//! The `dth` command ([`dth_examples::cli`]).

fn main() -> std::process::ExitCode {
    dth_examples::cli::main()
}
