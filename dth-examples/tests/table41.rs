//! `dth table41 --json PATH` reproduces the thesis's Table 4.1, through the binary.

mod common;

use common::*;

use dth::kepler::THESIS_TABLE_4_1 as THESIS;

/// An entry is "at roundoff" when the thesis's value is: below 1e-13, i.e. a few hundred eps
/// times the O(1) energy and angular momentum. Ours must then be at most 3e-14: the
/// average of |Q_k - Q_0| for a quantity conserved exactly by the method is a random walk of
/// roundoff, a few eps sqrt(k) at worst over 10^4 steps.
const ROUNDOFF: f64 = 1e-13;

#[test]
fn table41_matches_the_thesis() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["table41", "--json", "t41.json"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let md = stdout(&o);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("t41.json")).unwrap())
            .unwrap();
    // Exactly {"rows": [{"method", "energy", "angular_momentum"}, ...]} in the thesis's order.
    let obj = json.as_object().unwrap();
    assert_eq!(obj.keys().collect::<Vec<_>>(), ["rows"]);
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), THESIS.len());
    for (row, t) in rows.iter().zip(&THESIS) {
        let (method, e_thesis, l_thesis) = (t.method, t.energy, t.angular_momentum);
        let mut keys: Vec<_> = row.as_object().unwrap().keys().cloned().collect();
        keys.sort();
        assert_eq!(keys, ["angular_momentum", "energy", "method"]);
        assert_eq!(row["method"], method);
        for (what, ours, thesis) in [
            ("energy", row["energy"].as_f64().unwrap(), e_thesis),
            (
                "angular_momentum",
                row["angular_momentum"].as_f64().unwrap(),
                l_thesis,
            ),
        ] {
            if thesis < ROUNDOFF {
                assert!(
                    (0.0..=3e-14).contains(&ours),
                    "{method} {what}: {ours:e} is not at roundoff"
                );
            } else {
                assert!(
                    ((ours - thesis) / thesis).abs() <= 0.01,
                    "{method} {what}: {ours:e} vs thesis {thesis:e}"
                );
            }
        }
        // The markdown shows the thesis's value beside ours.
        assert!(
            md.lines().any(|l| l.starts_with(&format!("| {method} |"))
                && l.contains(&format!("{e_thesis:.3e}"))),
            "{md}"
        );
    }
    // The DTH midpoint energy is no worse than the thesis's 1.285e-14.
    let dth_energy = rows[3]["energy"].as_f64().unwrap();
    assert!(dth_energy <= 1.285e-14, "{dth_energy:e}");
    // Nothing but the requested file is written.
    assert_eq!(entries(dir.path()), ["t41.json"]);
}
