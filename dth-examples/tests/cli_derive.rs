//! `dth derive "EXPR"`: what the engine derives, and malformed expressions as exit 2 with the
//! position of every error.

mod common;

use common::*;

#[test]
fn derive_prints_gradient_hessian_psi_and_flags() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(
        &[
            "derive",
            "p1^2/(2*m) - m*g*l*cos(q1)",
            "--param",
            "m,g",
            "-p",
            "l",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    for line in [
        "z = (q1, p1)",
        "parameters: m, g, l",
        "dH/dq1 = ",
        "dH/dp1 = p1*m^(-1)",
        "d2H/dp1dp1 = m^(-1)",
        "Psi = (J gradH)^T HessH (J gradH)",
        "separable: yes",
        "time-dependent: no",
        "Psi identically zero: no",
    ] {
        assert!(out.contains(line), "missing `{line}` in\n{out}");
    }
    // Nothing was written.
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn a_malformed_expression_is_exit_2_with_every_error_located() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["derive", "p1^2 + x1 + y"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(err.contains("unknown variable `x1`"), "{err}");
    assert!(
        err.contains("(column 8)\n  p1^2 + x1 + y\n         ^^"),
        "{err}"
    );
    assert!(err.contains("`y`"), "{err}");
    assert!(stdout(&o).is_empty());
}
