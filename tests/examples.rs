//! Every program in `examples/` compiled and run: the tasks a user starts with keep working
//! as the API changes. (`cargo run --release -p dth --example NAME` prints what they show;
//! their `main` is `pub` so that this file can call it.)

#[path = "../examples/compare_methods.rs"]
mod compare_methods;
#[path = "../examples/high_order.rs"]
mod high_order;
#[path = "../examples/lattice.rs"]
mod lattice;
#[path = "../examples/parameter_sweep.rs"]
mod parameter_sweep;
#[path = "../examples/robust.rs"]
mod robust;

#[test]
fn compare_methods_runs() -> Result<(), dth::Error> {
    compare_methods::main()
}

#[test]
fn high_order_runs() -> Result<(), dth::Error> {
    high_order::main()
}

#[test]
fn lattice_runs() -> Result<(), dth::Error> {
    lattice::main()
}

#[test]
fn parameter_sweep_runs() -> Result<(), dth::Error> {
    parameter_sweep::main()
}

#[test]
fn robust_runs() -> Result<(), dth::Error> {
    robust::main()
}
