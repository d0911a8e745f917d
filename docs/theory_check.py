#!/usr/bin/env python3
"""Recompute the numbers docs/theory.md and docs/thesis.md quote, independently of the Rust code.

Standard library only: `python3 docs/theory_check.py` (about half a minute). A deliberately
plain reimplementation (dense Gaussian elimination, joint Newton with the plain energy residual
against H(zbar_0)), not a model of the library: it checks the theory page's conventions and
derivations, not the library's numerics.

Prints:
- the thesis's Kepler orbit (E, L, a, e, period by Kepler's third law and by RK4 integration,
  Psi at pericentre and apocentre);
- the spurious root: one joint Newton iteration from zbar_k lands on (zbar_k, -lambda_k);
- a DTH run at the thesis's Table 4.1 settings: mean lambda, orbits reached, the spread of the
  law-of-time product lambda^3 Psi, and the DTH rows of Table 4.1 with the vertex reference
  z^(0) (the convention of docs/thesis.md#table-4-1) and, for contrast, zbar_0;
- the trapezoidal and implicit-midpoint rows of Table 4.1 (reference: the initial value).
"""

import math

EPS = 2.0**-52


def value(z):
    q1, q2, p1, p2 = z
    return p1 * p1 + p2 * p2 - 1.0 / math.sqrt(q1 * q1 + q2 * q2)


def gradient(z):
    q1, q2, p1, p2 = z
    r3 = (q1 * q1 + q2 * q2) ** 1.5
    return [q1 / r3, q2 / r3, 2.0 * p1, 2.0 * p2]


def hessian(z):
    q1, q2, _, _ = z
    r2 = q1 * q1 + q2 * q2
    r3, r5 = r2**1.5, r2**2.5
    a, b, c = 1 / r3 - 3 * q1 * q1 / r5, -3 * q1 * q2 / r5, 1 / r3 - 3 * q2 * q2 / r5
    return [[a, b, 0, 0], [b, c, 0, 0], [0, 0, 2, 0], [0, 0, 0, 2]]


def j_times(v):
    return [v[2], v[3], -v[0], -v[1]]


def angular_momentum(z):
    return z[0] * z[3] - z[1] * z[2]


def psi(z):
    w, hs = j_times(gradient(z)), hessian(z)
    return sum(w[i] * hs[i][j] * w[j] for i in range(4) for j in range(4))


def solve(a, b):
    """Gaussian elimination with partial pivoting."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(c + 1, n):
            f = m[r][c] / m[c][c]
            for j in range(c, n + 1):
                m[r][j] -= f * m[c][j]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (m[r][n] - sum(m[r][j] * x[j] for j in range(r + 1, n))) / m[r][r]
    return x


def newton_matrix(z, c):
    """I - c J Hess H(z)."""
    hs = hessian(z)
    jh = [[(hs[i + 2][j] if i < 2 else -hs[i - 2][j]) for j in range(4)] for i in range(4)]
    return [[(1.0 if i == j else 0.0) - c * jh[i][j] for j in range(4)] for i in range(4)]


def joint_newton(zk, lk, h, energy, z, lam, max_iterations=50):
    """Joint Newton on (z, lambda) for one DTH step (docs/solver.md#joint-newton)."""
    gk = gradient(zk)
    last = math.inf
    for iteration in range(1, max_iterations + 1):
        g = gradient(z)
        rhs = j_times([lam * g[i] + lk * gk[i] for i in range(4)])
        f = [z[i] - zk[i] - 0.5 * h * rhs[i] for i in range(4)]
        a = newton_matrix(z, 0.5 * h * lam)
        jg = j_times(g)
        bordered = [a[i] + [-0.5 * h * jg[i]] for i in range(4)] + [g + [0.0]]
        d = solve(bordered, [-x for x in f] + [-(value(z) - energy)])
        z = [z[i] + d[i] for i in range(4)]
        lam += d[4]
        u = max(max(abs(d[i]) for i in range(4)) / max(abs(x) for x in z), abs(d[4] / lam))
        if u <= 4 * EPS or (u < 1e-12 and u > 0.5 * last):
            break
        last = u
    return z, lam, iteration


def kepler_orbit():
    m, k = 0.5, 1.0
    q, p = (0.5, 0.0), (0.0, 1.2)
    e_ = (p[0] ** 2 + p[1] ** 2) / (2 * m) - k / math.hypot(*q)
    l_ = q[0] * p[1] - q[1] * p[0]
    a = k / (2 * abs(e_))
    ecc = math.sqrt(1 + 2 * e_ * l_**2 / (m * k * k))
    period = 2 * math.pi * math.sqrt(m * a**3 / k)
    print("Kepler orbit of thesis Section 4.2 (docs/thesis.md#kepler-orbit)")
    print(f"  E = {e_}, L = {l_}, a = {a:.6f}, e = {ecc:.6f}")
    print(f"  pericentre {a * (1 - ecc):.6f}, apocentre {a * (1 + ecc):.6f}")
    print(f"  period (Kepler's third law) {period:.6f}")

    def rhs(s):
        x, y, u, v = s
        r3 = (x * x + y * y) ** 1.5
        return (u / m, v / m, -k * x / r3, -k * y / r3)

    s, t, dt = [0.5, 0.0, 0.0, 1.2], 0.0, 1e-4
    while True:
        k1 = rhs(s)
        k2 = rhs([s[i] + dt / 2 * k1[i] for i in range(4)])
        k3 = rhs([s[i] + dt / 2 * k2[i] for i in range(4)])
        k4 = rhs([s[i] + dt * k3[i] for i in range(4)])
        n = [s[i] + dt / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) for i in range(4)]
        if t > 1 and s[1] < 0 <= n[1]:
            print(f"  period (RK4, dt = 1e-4, next upward crossing of q2 = 0) {t - s[1] / (n[1] - s[1]) * dt:.6f}")
            break
        s, t = n, t + dt
    apo = [a * (1 + ecc), 0.0, 0.0, -l_ / (a * (1 + ecc))]
    print(f"  Psi at pericentre {psi([0.5, 0.0, 0.0, 1.2]):.4f}, at apocentre {psi(apo):.4f}")
    print(f"  sqrt(5/8) = {math.sqrt(5 / 8):.4f} (Psi > 0 along an orbit iff e below it)")
    return period


def spurious_root(h):
    z0 = [0.5, 0.0, 0.0, 1.2]
    print("Spurious root (docs/theory.md#spurious-root): one joint Newton iteration from zbar_k")
    for start in (1.0, 2.5, -0.3):
        z, lam, _ = joint_newton(z0, 1.0, h, value(z0), z0[:], start, max_iterations=1)
        dz = max(abs(z[i] - z0[i]) for i in range(4))
        print(f"  lambda start {start:+.1f}: lambda -> {lam:.15f}, |dz| = {dz:.1e}")


def dth_table41(h, n, period):
    zbar = [[0.5, 0.0, 0.0, 1.2]]
    lam = [1.0]
    energy = value(zbar[0])
    iterations = 0
    for _ in range(n):
        zk, lk = zbar[-1], lam[-1]
        v = [zk[i] + 0.5 * h * lk * j_times(gradient(zk))[i] for i in range(4)]
        # predictor: two fixed-point sweeps from the vertex, lambda_k (never start at zbar_k)
        z1 = [v[i] + 0.5 * h * lk * j_times(gradient(v))[i] for i in range(4)]
        zp = [v[i] + 0.5 * h * lk * j_times(gradient(z1))[i] for i in range(4)]
        z, l_, it = joint_newton(zk, lk, h, energy, zp, lk)
        assert l_ > 0, "spurious root"
        zbar.append(z)
        lam.append(l_)
        iterations += it
    tbar = 0.0
    for k in range(n):
        tbar += 0.5 * h * (lam[k] + lam[k + 1])
    law = [lam[k] ** 3 * psi(zbar[k]) for k in range(n + 1)]
    print(f"DTH at dtau = {h}, lambda_0 = 1, {n} steps (docs/thesis.md#table-4-1)")
    print(f"  mean lambda {sum(lam[:n]) / n:.4f} (0.15/dtau = {0.15 / h:.4f}); "
          f"tbar_N = {tbar:.2f} = {tbar / period:.2f} orbits; mean Newton iterations "
          f"{iterations / n:.2f}")
    print(f"  lambda from {min(lam):.3f} to {max(lam):.3f}; lambda^3 Psi from {min(law):.3f} "
          f"to {max(law):.3f} (docs/theory.md#law-of-time)")
    vertices = [[zbar[k][i] - 0.5 * h * lam[k] * j_times(gradient(zbar[k]))[i] for i in range(4)]
                for k in range(n + 1)]

    def average(points, ref):
        e0, l0 = value(ref), angular_momentum(ref)
        return (sum(abs(value(z) - e0) for z in points[1:]) / n,
                sum(abs(angular_momentum(z) - l0) for z in points[1:]) / n)

    print("  %-38s energy %.3e  L %.3e" % (("midpoints, ref zbar_0",) + average(zbar, zbar[0])))
    print("  %-38s energy %.3e  L %.3e" % (("vertices, ref z^(0) (the convention)",)
                                           + average(vertices, vertices[0])))
    print("  %-38s energy %.3e  L %.3e" % (("vertices, ref zbar_0 (not it)",)
                                           + average(vertices, zbar[0])))


def peer_table41(dt, n):
    print(f"Fixed-step methods at dt = {dt}, {n} steps, reference the initial value")
    for name in ("trapezoidal", "midpoint"):
        z = [0.5, 0.0, 0.0, 1.2]
        e0, l0 = value(z), angular_momentum(z)
        se = sl = 0.0
        for _ in range(n):
            z0, g0 = z, j_times(gradient(z))
            z = [z0[i] + dt * g0[i] for i in range(4)]
            for _ in range(50):
                if name == "midpoint":
                    mid = [(z0[i] + z[i]) / 2 for i in range(4)]
                    f = [z[i] - z0[i] - dt * j_times(gradient(mid))[i] for i in range(4)]
                    a = newton_matrix(mid, dt / 2)
                else:
                    g1 = j_times(gradient(z))
                    f = [z[i] - z0[i] - dt / 2 * (g0[i] + g1[i]) for i in range(4)]
                    a = newton_matrix(z, dt / 2)
                d = solve(a, [-x for x in f])
                z = [z[i] + d[i] for i in range(4)]
                if max(abs(x) for x in d) <= 4 * EPS * max(abs(x) for x in z):
                    break
            se += abs(value(z) - e0)
            sl += abs(angular_momentum(z) - l0)
        print("  %-38s energy %.3e  L %.3e" % (name, se / n, sl / n))


if __name__ == "__main__":
    T = kepler_orbit()
    spurious_root(0.06277)
    dth_table41(0.06277, 10_000, T)
    peer_table41(0.15, 10_000)
