// Warnings, made errors here so that trybuild shows them.
#![deny(deprecated)]

fn main() {
    // Meant q3: q2 never moves (a warning), and beside it p3 without q3 looks misnumbered.
    let _h = dth::hamiltonian!(p1^2/2 + p3^2/2 + q1^2 + q2^2);
}
