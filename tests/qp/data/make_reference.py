#!/usr/bin/python3
"""Writes tests/qp/data/reference.json: QP instances with the answers of a second solver,
Debian's python3-cvxopt (an interior-point method), for tests/qp/qp_reference_test.cc.

Run with Debian's interpreter (the one that sees python3-cvxopt):
    /usr/bin/python3 tests/qp/data/make_reference.py

It also writes tests/qp/data/contact_id/answers.json, cvxopt's answers for the QPs captured from
the contact inverse dynamics in tests/qp/data/contact_id/ (see contact_id()).

Each instance stores the data so that C++ rebuilds exactly the same problem:
    H = Fᵀ F (F absent: H = 0),  g = Fᵀ c + g0,  lb ≤ x ≤ ub,  lbA ≤ A x ≤ ubA
(null for an infinite bound; numbers rounded to 6 significant digits before solving, so the JSON
*is* the problem). Storing F rather than H keeps a rank-deficient H exactly positive
semi-definite after rounding, and c keeps g in range(Fᵀ) where boundedness depends on it.
The answer: "status" ("optimal" / "infeasible"), "objective", "x" and "unique" (x is unique
when H is positive definite; otherwise only the objective is compared).
"""
import json
import math
import os
import sys

import numpy as np
from cvxopt import matrix, solvers

solvers.options.update(show_progress=False, abstol=1e-11, reltol=1e-11, feastol=1e-11,
                       maxiters=200)
rng = np.random.default_rng(20261123)


def r6(a):
    """Round to 6 significant digits (the stored, and therefore the true, data)."""
    a = np.asarray(a, dtype=float)
    out = np.zeros_like(a)
    nz = a != 0
    e = np.floor(np.log10(np.abs(a[nz])))
    out[nz] = np.round(a[nz] / 10.0**(e - 5)) * 10.0**(e - 5)
    return np.array([float('%.6g' % v) for v in out.ravel()]).reshape(a.shape)


def jnum(v):
    return None if not math.isfinite(v) else float('%.6g' % v)


def solve_cvxopt(H, g, A, lbA, ubA, lb, ub, feasibility_only=False):
    n = len(g)
    G, h, E, e = [], [], [], []
    for i in range(n):
        if lb[i] == ub[i]:
            row = np.zeros(n); row[i] = 1; E.append(row); e.append(lb[i]); continue
        if math.isfinite(ub[i]):
            row = np.zeros(n); row[i] = 1; G.append(row); h.append(ub[i])
        if math.isfinite(lb[i]):
            row = np.zeros(n); row[i] = -1; G.append(row); h.append(-lb[i])
    for k in range(len(lbA)):
        if lbA[k] == ubA[k]:
            E.append(A[k]); e.append(lbA[k]); continue
        if math.isfinite(ubA[k]):
            G.append(A[k]); h.append(ubA[k])
        if math.isfinite(lbA[k]):
            G.append(-A[k]); h.append(-lbA[k])
    args = [matrix(H), matrix(g)]
    args += [matrix(np.array(G)), matrix(np.array(h))] if G else [None, None]
    args += [matrix(np.array(E)), matrix(np.array(e))] if E else [None, None]
    try:
        if feasibility_only:  # the LP solver returns Farkas certificates, the QP one rarely
            args[0:2] = [matrix(np.zeros(n))]
            sol = solvers.lp(*args)
        else:
            sol = solvers.qp(*args)
    except (ValueError, ArithmeticError):  # cvxopt gives up on some infeasible problems
        return 'error', None
    x = np.array(sol['x']).ravel() if sol['x'] is not None else None
    return sol['status'], x


def instance(name, F, c, g0, A, lbA, ubA, lb, ub, unique, expect=None):
    n = len(lb)
    F = r6(F) if F is not None else None
    c = r6(c) if c is not None else None
    g0 = r6(g0)
    A = r6(A).reshape(len(lbA), n)
    lbA, ubA, lb, ub = [np.array([v if not math.isfinite(v) else float('%.6g' % v) for v in a])
                        for a in (lbA, ubA, lb, ub)]
    H = F.T @ F if F is not None else np.zeros((n, n))
    g = g0 + (F.T @ c if c is not None else 0)
    status, x = solve_cvxopt(H, g, A, lbA, ubA, lb, ub, expect == 'infeasible')
    if status == 'primal infeasible':
        status = 'infeasible'
    if expect is not None and status != expect:
        return None
    if status not in ('optimal', 'infeasible'):
        return None
    d = {"name": name, "n": n, "m": len(lbA), "g0": [jnum(v) for v in g0],
         "A": [[jnum(v) for v in row] for row in A],
         "lbA": [jnum(v) for v in lbA], "ubA": [jnum(v) for v in ubA],
         "lb": [jnum(v) for v in lb], "ub": [jnum(v) for v in ub],
         "status": status, "unique": bool(unique)}
    if F is not None:
        d["F"] = [[jnum(v) for v in row] for row in F]
    if c is not None:
        d["c"] = [jnum(v) for v in c]
    if status == 'optimal':
        d["objective"] = float(0.5 * x @ H @ x + g @ x)
        d["x"] = [float(v) for v in x]
    return d


def sides(values, active_frac, inf_frac, eq_frac=0.0):
    lo, hi = np.empty(len(values)), np.empty(len(values))
    for i, v in enumerate(values):
        if rng.random() < eq_frac:
            lo[i] = hi[i] = v; continue
        lo[i] = -math.inf if rng.random() < inf_frac else v - rng.uniform(0.0, 1.0)
        hi[i] = math.inf if rng.random() < inf_frac else v + rng.uniform(0.0, 1.0)
    return lo, hi


def random_qp(name, n, m, cond, eq_frac=0.0):
    # strictly convex: F square with singular values spread over sqrt(cond)
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    s = np.logspace(0, -0.5 * math.log10(cond), n)
    F = U @ np.diag(s) @ V.T
    x0 = rng.uniform(-1, 1, n)
    A = rng.standard_normal((m, n))
    lbA, ubA = sides(A @ x0, 0.5, 0.3, eq_frac)
    lb, ub = sides(x0, 0.5, 0.5)
    g0 = 3.0 * rng.standard_normal(n)
    return instance(name, F, None, g0, A, lbA, ubA, lb, ub, True)


def singular_qp(name, n, m, rank):
    # rank-deficient H with a box (so bounded whatever g is)
    F = rng.standard_normal((rank, n))
    x0 = rng.uniform(-1, 1, n)
    A = rng.standard_normal((m, n))
    lbA, ubA = sides(A @ x0, 0.5, 0.3)
    lb, ub = x0 - rng.uniform(0.2, 2, n), x0 + rng.uniform(0.2, 2, n)
    g0 = rng.standard_normal(n)
    return instance(name, F, None, g0, A, lbA, ubA, lb, ub, False)


def lp(name, n, m):
    x0 = rng.uniform(-1, 1, n)
    A = rng.standard_normal((m, n))
    lbA, ubA = sides(A @ x0, 0.5, 0.4)
    lb, ub = x0 - rng.uniform(0.2, 2, n), x0 + rng.uniform(0.2, 2, n)
    return instance(name, None, None, rng.standard_normal(n), A, lbA, ubA, lb, ub, False)


def id_shaped(name, feet):
    # Stage I of the two-stage ID (DESIGN.md §2): z = [c_N, c_D(4)] per foot, H = Zᵀ M Z with
    # Z 6 × 5·feet (rank ≤ 6), g = Zᵀ M p; z ≥ 0; μ c_N − Σ c_D ≥ 0; n_fᵀ (Z z + p) ≥ 0.
    nz = 5 * feet
    G = rng.standard_normal((6, 6))
    M = G @ G.T + 6 * np.eye(6)
    R = np.linalg.cholesky(M).T
    Z = 0.05 * rng.standard_normal((6, nz))
    p = 0.3 * rng.standard_normal(6)
    F = R @ Z
    c = R @ p
    A, lbA = [], []
    for f in range(feet):
        row = np.zeros(nz); row[5 * f] = rng.uniform(0.1, 1.0); row[5 * f + 1:5 * f + 5] = -1
        A.append(row); lbA.append(0.0)
    z0 = np.zeros(nz)
    for f in range(feet):
        z0[5 * f] = rng.uniform(0.5, 1.5); z0[5 * f + 1:5 * f + 5] = 0.02 * rng.random(4)
    for f in range(feet):
        nrow = rng.standard_normal(6)
        A.append(nrow @ Z); lbA.append(min(-(nrow @ p), nrow @ Z @ z0))
    m = len(lbA)
    return instance(name, F, c, np.zeros(nz), np.array(A), np.array(lbA), np.full(m, math.inf),
                    np.zeros(nz), np.full(nz, math.inf), False)


def infeasible(name, n, m):
    x0 = rng.uniform(-1, 1, n)
    A = rng.standard_normal((m, n))
    lbA = A @ x0 - rng.uniform(0.1, 1.0, m)
    ubA = np.full(m, math.inf)
    w = rng.uniform(0.2, 1.0, m)
    A = np.vstack([A, w @ A])
    lbA = np.append(lbA, -math.inf)
    ubA = np.append(ubA, w @ lbA[:m] - 1.0)
    lb, ub = x0 - 3, x0 + 3
    U = rng.standard_normal((n, n))
    return instance(name, U, None, rng.standard_normal(n), A, lbA, ubA, lb, ub, True,
                    expect='infeasible')


def main():
    out = []
    makers = []
    for i in range(80):
        n = int(rng.integers(2, 16)); m = int(rng.integers(0, 2 * n + 1))
        cond = 10.0 ** rng.uniform(0, 6)
        makers.append(lambda i=i, n=n, m=m, cond=cond: random_qp("random_%d" % i, n, m, cond))
    for i in range(20):
        n = int(rng.integers(3, 12)); m = int(rng.integers(1, n + 1))
        makers.append(lambda i=i, n=n, m=m: random_qp("equality_%d" % i, n, m, 1e2, 0.3))
    for i in range(40):
        n = int(rng.integers(3, 16)); m = int(rng.integers(0, n + 1)); k = int(rng.integers(1, n))
        makers.append(lambda i=i, n=n, m=m, k=k: singular_qp("singular_%d" % i, n, m, k))
    for i in range(30):
        n = int(rng.integers(2, 12)); m = int(rng.integers(0, n + 1))
        makers.append(lambda i=i, n=n, m=m: lp("lp_%d" % i, n, m))
    for i in range(40):
        feet = int(rng.integers(2, 5)) if i % 3 else 4
        makers.append(lambda i=i, feet=feet: id_shaped("id_%dfeet_%d" % (feet, i), feet))
    for i in range(20):
        n = int(rng.integers(2, 10)); m = int(rng.integers(1, 8))
        makers.append(lambda i=i, n=n, m=m: infeasible("infeasible_%d" % i, n, m))
    skipped = 0
    for make in makers:
        d = make()
        if d is None:
            skipped += 1
        else:
            out.append(d)
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "reference.json")
    with open(path, "w") as f:
        json.dump({"generator": "tests/qp/data/make_reference.py",
                   "reference_solver": "cvxopt %s (Debian python3-cvxopt)" %
                   __import__("cvxopt").__version__,
                   "instances": out}, f, separators=(",", ":"))
        f.write("\n")
    print("%d instances (%d skipped: cvxopt not optimal/infeasible as expected) -> %s" %
          (len(out), skipped, path), file=sys.stderr)


def load_tool_json(path):
    """A problem in hyq-qp-solve's format (null = infinite bound), as solve_cvxopt's arguments."""
    with open(path) as f:
        d = json.load(f)
    n = len(d["g"])
    num = lambda v, inf: inf if v is None else float(v)
    A = np.array(d.get("A", []), dtype=float).reshape(-1, n)
    lbA = np.array([num(v, -math.inf) for v in d.get("lbA", [])])
    ubA = np.array([num(v, math.inf) for v in d.get("ubA", [])])
    lb = np.array([num(v, -math.inf) for v in d.get("lb", [None] * n)])
    ub = np.array([num(v, math.inf) for v in d.get("ub", [None] * n)])
    return np.array(d["H"], dtype=float), np.array(d["g"], dtype=float), A, lbA, ubA, lb, ub


def contact_id():
    """tests/qp/data/contact_id/answers.json: cvxopt's answers for the QPs captured from the
    two-stage contact inverse dynamics (full-precision data, kept as they were captured: rounding
    them would break the exact dependence of their rows that makes them hard). cvxopt solves
    each twice: with its default tolerances (status "optimal" on all of them) and with the tight
    ones used above (closer objective; cvxopt may stop with "unknown" there on the most degenerate
    ones, with its x still feasible to ~1e-11)."""
    folder = os.path.join(os.path.dirname(os.path.abspath(__file__)), "contact_id")
    tight = dict(solvers.options)
    answers = []
    for name in sorted(os.listdir(folder)):
        if not name.endswith(".json") or name == "answers.json":
            continue
        H, g, A, lbA, ubA, lb, ub = load_tool_json(os.path.join(folder, name))
        entry = {"file": name}
        for key, opts in (("default", {}), ("tight", tight)):
            solvers.options.clear()
            solvers.options.update(opts)
            solvers.options["show_progress"] = False
            status, x = solve_cvxopt(H, g, A, lbA, ubA, lb, ub)
            ax = A @ x if len(lbA) else np.zeros(0)
            violation = max([0.0] + list(lbA - ax) + list(ax - ubA) + list(lb - x) + list(x - ub))
            entry[key] = {"status": status, "objective": float(0.5 * x @ H @ x + g @ x),
                          "max_violation": float(violation), "x": [float(v) for v in x]}
        answers.append(entry)
    solvers.options.clear()
    solvers.options.update(tight)
    path = os.path.join(folder, "answers.json")
    with open(path, "w") as f:
        json.dump({"generator": "tests/qp/data/make_reference.py (contact_id)",
                   "reference_solver": "cvxopt %s (Debian python3-cvxopt)" %
                   __import__("cvxopt").__version__,
                   "answers": answers}, f, indent=1)
        f.write("\n")
    print("%d contact-ID instances -> %s" % (len(answers), path), file=sys.stderr)


if __name__ == "__main__":
    main()
    contact_id()
