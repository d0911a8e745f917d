#!/usr/bin/env bash
# What a user pays in rustc for `hamiltonian!`: wall time of `cargo build` (dev, then release)
# of a one-file crate holding one system, against the same crate empty, median of 3 builds.
# Dependencies come prebuilt from the workspace's target directory (built once per profile,
# not timed); only the leaf crate compiles, with incremental compilation off (it would reuse
# the macro's and the constant evaluator's results across the timed rebuilds, which touch a
# file whose tokens do not change). Run from the workspace root:
#
#     bash dth-symbolic/benches/rustc_time.sh toda [SIZES...]   # default 2 4 .. 20
#     bash dth-symbolic/benches/rustc_time.sh fput [SIZES...]   # default 64 4096
#
# `toda`: a Toda chain between walls written out term by term, n degrees of freedom, every
# trait method used (docs/performance.md, "Compile cost of hamiltonian!"; the engine's own time
# is `dth-examples/benches/compile_cost.rs`). `fput`: the FPUT-alpha chain written once as a
# sum, `N` sites, compiled to loops, every method a large chain can use (all but the dense
# `hessian` and `derivatives`, a D x D matrix: 512 MB at D = 8192) ("Lattices written once";
# the expansion time and size are `benches/indexed_expand.rs`). Prints a markdown table.
set -euo pipefail
export CARGO_INCREMENTAL=0

system=${1:-}
shift || true
sizes=("$@")
case "$system" in
toda) [ ${#sizes[@]} -gt 0 ] || sizes=(2 4 6 8 10 12 14 16 18 20) ;;
fput) [ ${#sizes[@]} -gt 0 ] || sizes=(64 4096) ;;
*)
    echo "usage: bash dth-symbolic/benches/rustc_time.sh toda|fput [SIZES...]" >&2
    exit 2
    ;;
esac

root=$(pwd)
dir="$root/target/rustc-time-$system"
mkdir -p "$dir/src"
cp "$root/Cargo.lock" "$dir/Cargo.lock"
cat >"$dir/Cargo.toml" <<TOML
[package]
name = "dth-rustc-time-$system"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
path = "src/lib.rs"

[dependencies]
# Not the run-time compiler (cranelift): the leaf crate is a library, nothing is linked.
dth = { path = "$root", default-features = false }

[workspace]

[profile.dev]
opt-level = 1

[profile.dev.package."*"]
opt-level = 3
TOML

toda_source() { # the chain's H, written out
    local n=$1 src="(" i
    for ((i = 1; i <= n; i++)); do src+="p$i^2"; [ $i -lt $n ] && src+=" + "; done
    src+=")/2 + exp(-q1)"
    for ((i = 1; i < n; i++)); do src+=" + exp(q$i - q$((i + 1)))"; done
    echo "$src + exp(q$n)"
}

leaf_crate() { # src/lib.rs for size $1
    local n=$1 d=$((2 * $1))
    case "$system" in
    toda)
        cat <<RS
dth::hamiltonian! {
    /// A Toda chain between walls.
    pub struct Toda = $(toda_source "$n")
}

/// Uses every method, so all of them are compiled (they are \`#[inline]\`: code is generated
/// where they are used).
pub fn all(z: &dth::nalgebra::SVector<f64, $d>) -> f64 {
    use dth::Hamiltonian;
    let d = Toda.derivatives(z);
    Toda.value(z) + Toda.gradient(z).sum() + Toda.hessian(z).sum() + Toda.psi(z) + d.psi
}
RS
        ;;
    fput)
        cat <<RS
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
        ;;
    esac
}

cargo_build() {
    CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml" "$@"
}

build_time() { # seconds for one build of the leaf crate
    local start end
    touch "$dir/src/lib.rs"
    start=$(date +%s.%N)
    cargo_build "$@"
    end=$(date +%s.%N)
    echo "$end - $start" | bc
}

median3() { # the median of three builds
    printf '%s\n' "$(build_time "$@")" "$(build_time "$@")" "$(build_time "$@")" | sort -g | sed -n 2p
}

# Warm-up: the dependencies, once per profile (not timed).
echo 'pub fn f() {}' >"$dir/src/lib.rs"
cargo_build
cargo_build --release
base_dev=$(median3)
base_rel=$(median3 --release)
size=$([ "$system" = toda ] && echo n || echo N)
echo "| $size | D | dev build (s) | dev, minus an empty crate (s) | release build (s) | release, minus an empty crate (s) |"
echo "|---|---|---|---|---|---|"
printf '| 0 (empty crate) | - | %.2f | 0 | %.2f | 0 |\n' "$base_dev" "$base_rel"
for n in "${sizes[@]}"; do
    leaf_crate "$n" >"$dir/src/lib.rs"
    dev=$(median3)
    rel=$(median3 --release)
    printf '| %d | %d | %.2f | %.2f | %.2f | %.2f |\n' "$n" $((2 * n)) "$dev" \
        "$(echo "$dev - $base_dev" | bc)" "$rel" "$(echo "$rel - $base_rel" | bc)"
done
