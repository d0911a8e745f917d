//! Compile-fail suite: each `tests/ui/<mistake>.rs` is a malformed Hamiltonian and its
//! `.stderr` the reviewed diagnostic; each `tests/ui/api/<mistake>.rs` is a use of the
//! library's API that no longer compiles (an old form removed), with the error that says so.
//! Regenerate with `TRYBUILD=overwrite cargo test -p dth --test ui` and review the diff; the
//! texts depend on the toolchain pinned in `rust-toolchain.toml`.

#[test]
fn ui() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
    t.compile_fail("tests/ui/api/*.rs");
}
