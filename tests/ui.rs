//! Compile-fail suite: each `tests/ui/<mistake>.rs` is a malformed Hamiltonian and its
//! `.stderr` the reviewed diagnostic. Regenerate with `TRYBUILD=overwrite cargo test -p dth
//! --test ui` and review the diff; the texts depend on the toolchain pinned in
//! `rust-toolchain.toml`.

#[test]
fn ui() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
