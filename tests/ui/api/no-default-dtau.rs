// DTH's step `dtau` has no default: the thesis's Kepler value (0.06277) once was one, applied
// silently to every system. `DthOptions::new(dtau)?` names it; the thesis's settings for its
// Kepler orbit are the preset `DthOptions::thesis_kepler()`.
use dth::DthOptions;

fn main() {
    let _ = DthOptions::default();
}
