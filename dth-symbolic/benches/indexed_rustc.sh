#!/usr/bin/env bash
# Wall time of `cargo build` (dev, then release) of a one-file crate holding the FPUT-alpha
# chain written once, `sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, ...) where N = .., q[0] =
# q[N+1] = 0`, through `hamiltonian!` (emitted as loops), for N = 64 and 4096, against an
# empty crate; plus the size of the macro's expansion (`cargo expand`-free: the bytes of
# `stringify!` of nothing but the generated impl are measured in-process by
# `benches/indexed_expand.rs`). Every method a large chain can use is called (all but the
# dense `hessian` and `derivatives`, a D x D matrix: 512 MB at D = 8192), so each is compiled.
# Dependencies come prebuilt from the workspace's target directory. Run from the root:
#
#     bash dth-symbolic/benches/indexed_rustc.sh [SIZES...]
#
# Prints a markdown table for docs/benchmarks.md ("Lattices written once").
set -euo pipefail
# Incremental compilation would reuse the macro's and the constant evaluator's results across
# the timed rebuilds (a touched file with the same tokens): every build starts cold.
export CARGO_INCREMENTAL=0

root=$(pwd)
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(64 4096)
dir="$root/target/indexed-rustc"
mkdir -p "$dir/src"
cp "$root/Cargo.lock" "$dir/Cargo.lock"
cat >"$dir/Cargo.toml" <<TOML
[package]
name = "dth-indexed-rustc"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
path = "src/lib.rs"

[dependencies]
dth = { path = "$root" }

[workspace]

[profile.dev]
opt-level = 1

[profile.dev.package."*"]
opt-level = 3
TOML

build_time() { # seconds for one build of the leaf crate
    local profile=$1 start end
    touch "$dir/src/lib.rs"
    start=$(date +%s.%N)
    CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml" $profile
    end=$(date +%s.%N)
    echo "$end - $start" | bc
}

median3() {
    printf '%s\n' "$(build_time "$1")" "$(build_time "$1")" "$(build_time "$1")" | sort -g | sed -n 2p
}

echo 'pub fn f() {}' >"$dir/src/lib.rs"
CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml"
CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml" --release
base_dev=$(median3 "")
base_rel=$(median3 --release)
echo "| N | D | dev build (s) | dev, minus an empty crate (s) | release build (s) | release, minus an empty crate (s) |"
echo "|---|---|---|---|---|---|"
printf '| 0 (empty crate) | - | %.2f | 0 | %.2f | 0 |\n' "$base_dev" "$base_rel"
for n in "${sizes[@]}"; do
    d=$((2 * n))
    cat >"$dir/src/lib.rs" <<RS
dth::hamiltonian! {
    /// FPUT-alpha written once.
    pub struct Fput { alpha: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = $n, q[0] = q[N+1] = 0
}

use dth::Hamiltonian;

/// Uses every method a large chain can use, so each is compiled.
pub fn use_all(z0: &dth::nalgebra::SVector<f64, $d>, z1: &dth::nalgebra::SVector<f64, $d>, values: &mut [f64]) -> f64 {
    let h = Fput { alpha: 0.25 };
    h.hessian_nonzeros(z0, values);
    h.value(z0) + h.gradient(z0)[0] + h.psi(z0) + h.discrete_gradient(z0, z1)[0]
        + h.energy_difference(z0, z1) + h.discrete_gradient_defect(z0, z1, z0)[0]
}
RS
    dev=$(median3 "")
    rel=$(median3 --release)
    printf '| %d | %d | %.2f | %.2f | %.2f | %.2f |\n' "$n" "$d" "$dev" "$(echo "$dev - $base_dev" | bc)" "$rel" "$(echo "$rel - $base_rel" | bc)"
done
