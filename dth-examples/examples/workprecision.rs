//! Run the work-precision benchmark until the `dth workprecision` subcommand exists:
//! `cargo run --release -p dth-examples --example workprecision -- [--quick] [OUT_DIR]`
//! (default output directory `target/workprecision`).

use std::path::PathBuf;
use std::process::ExitCode;

use dth_examples::workprecision::{run, WorkPrecisionOptions};

fn main() -> ExitCode {
    let mut quick = false;
    let mut out = PathBuf::from("target/workprecision");
    for arg in std::env::args().skip(1) {
        if arg == "--quick" {
            quick = true;
        } else {
            out = PathBuf::from(arg);
        }
    }
    let options = if quick {
        WorkPrecisionOptions::quick()
    } else {
        WorkPrecisionOptions::default()
    };
    match run(&options, &out) {
        Ok(summary) => {
            println!("{}", summary.tables);
            for f in &summary.files {
                println!("wrote {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            dth_examples::cli::print_error(&e);
            ExitCode::FAILURE
        }
    }
}
