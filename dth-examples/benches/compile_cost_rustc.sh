#!/usr/bin/env bash
# Wall time of `cargo build` (dev, then release) of a one-file crate holding a Toda chain
# `hamiltonian!` of n = 2..20 degrees of freedom (every trait method used), against an empty
# crate: what a user pays at compile time, beyond the in-process
# engine time of `benches/compile_cost.rs`. Dependencies come prebuilt from the workspace's
# target directory; only the leaf crate compiles. Run from the workspace root:
#
#     bash dth-examples/benches/compile_cost_rustc.sh [SIZES...]
#
# Prints a markdown table. Results go into docs/benchmarks.md ("Compile cost of hamiltonian!").
set -euo pipefail

root=$(pwd)
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(2 4 6 8 10 12 14 16 18 20)
dir="$root/target/compile-cost"
mkdir -p "$dir/src"
cp "$root/Cargo.lock" "$dir/Cargo.lock"
cat >"$dir/Cargo.toml" <<EOF
[package]
name = "dth-compile-cost"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
path = "src/lib.rs"

[dependencies]
dth = { path = "$root" }

[workspace]

# The workspace's profiles, so the prebuilt dependencies are reused.
[profile.dev]
opt-level = 1

[profile.dev.package."*"]
opt-level = 3
EOF

source_of() { # the chain's H
    local n=$1 src="(" i
    for ((i = 1; i <= n; i++)); do src+="p$i^2"; [ $i -lt $n ] && src+=" + "; done
    src+=")/2 + exp(-q1)"
    for ((i = 1; i < n; i++)); do src+=" + exp(q$i - q$((i + 1)))"; done
    echo "$src + exp(q$n)"
}

build_time() { # seconds for one build of the leaf crate
    local profile=$1 start end
    touch "$dir/src/lib.rs"
    start=$(date +%s.%N)
    CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml" $profile
    end=$(date +%s.%N)
    echo "$end - $start" | bc
}

median3() { # the median of three builds
    printf '%s\n' "$(build_time "$1")" "$(build_time "$1")" "$(build_time "$1")" | sort -g | sed -n 2p
}

# Warm-up: build the dependencies once per profile (not timed).
echo 'pub fn f() {}' >"$dir/src/lib.rs"
CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml"
CARGO_TARGET_DIR="$root/target" cargo build -q --manifest-path "$dir/Cargo.toml" --release
base_dev=$(median3 "")
base_rel=$(median3 --release)
echo "| n | D | dev build (s) | dev, minus an empty crate (s) | release build (s) | release, minus an empty crate (s) |"
echo "|---|---|---|---|---|---|"
printf '| 0 (empty crate) | - | %.2f | 0 | %.2f | 0 |\n' "$base_dev" "$base_rel"
for n in "${sizes[@]}"; do
    cat >"$dir/src/lib.rs" <<EOF
dth::hamiltonian! {
    /// A Toda chain between walls.
    pub struct Toda = $(source_of "$n")
}

/// Uses every method, so all of them are compiled (they are \`#[inline]\`: code is generated
/// where they are used).
pub fn all(z: &dth::nalgebra::SVector<f64, $((2 * n))>) -> f64 {
    use dth::Hamiltonian;
    let d = Toda.derivatives(z);
    Toda.value(z) + Toda.gradient(z).sum() + Toda.hessian(z).sum() + Toda.psi(z) + d.psi
}
EOF
    dev=$(median3 "")
    rel=$(median3 --release)
    printf '| %d | %d | %.2f | %.2f | %.2f | %.2f |\n' "$n" $((2 * n)) "$dev" \
        "$(echo "$dev - $base_dev" | bc)" "$rel" "$(echo "$rel - $base_rel" | bc)"
done
