"""Benchmark of inkray depth: the exact QP against OSQP (and Clarabel).

Run as ``python benchmarks/bench_depth.py [--sizes 512,1024] [--constraints 10,50]
[--no-osqp] [--no-clarabel] [--no-fast] [--repeat N]``.

The problem is the one :func:`inkray.depthmap.estimation.depth` solves: the weighted
4-neighbour Laplacian of a real drawing (the bundled turtle, resampled to
each size) and ``m`` order constraints between paper pixels, made consistent
by orienting each random pair along a random total order. The baselines get
the same QP: ``P = L``, the constraint rows, and the gauge as one more
equality row (``sum d = 0``; the exact solver grounds a pixel and shifts to
zero mean, which is the same minimizer). Reported per case: wall time, max
constraint violation, relative objective difference to the exact solution,
max depth difference, and the time ratio baseline / exact.

A second table times the fast method on the 512x512 turtle, with its region
scribbles and without: the first solve, then five edits, each an order added
(new points), solved, removed and solved again in the same session, against
the 0.2 s target for one incremental re-solve; each session also once with
:meth:`DepthSession.prepare` after the first solve (as the editor does while
the user looks at the opened drawing; its time in its own column), so that
the first edit pinning cannot follow is an update; and the exact method's
re-solve when its factorization is kept (the Laplacian depends on the drawing
only, so a new constraint costs the dual matrix and one solve).
"""

import argparse
import sys
import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from PIL import Image

from inkray.input.annotations import Order
from inkray.depthmap.estimation import DepthSession, depth_constraints
from inkray.input.drawing import drawing_from_array
from inkray.examples import example_path
from inkray.input.loading import load_input
from inkray.numerics.grid_cholesky import _front, _plan
from inkray.depthmap.quadratic_program import GroundedLaplacian, solve_depth_qp
from inkray.numerics.grid import edge_weights, grid_laplacian
from inkray.input.scribbles import seed_image


def problem(size, m, seed=0):
    """Laplacian of the turtle at ``size x size`` and ``m`` consistent order constraints."""
    ann, drawing = load_input(example_path("turtle"))
    rgb = np.asarray(Image.fromarray(drawing.rgb).resize((size, size), Image.LANCZOS))
    gray = drawing_from_array(rgb).gray.astype(np.float64)
    wx, wy, _ = edge_weights(gray)
    L = grid_laplacian(wx, wy)
    rng = np.random.default_rng(seed)
    paper = np.flatnonzero(gray.ravel() > 0.8)
    pts = rng.choice(paper, size=(m, 2), replace=False)
    rank = rng.permutation(size * size)
    front = rank[pts[:, 0]] > rank[pts[:, 1]]
    p = np.where(front, pts[:, 0], pts[:, 1])
    q = np.where(front, pts[:, 1], pts[:, 0])
    return L, p, q, (size, size)


def _baseline_matrices(L, p, q):
    n, m = L.shape[0], len(p)
    C = sp.csc_matrix((np.tile([1.0, -1.0], m), (np.repeat(np.arange(m), 2),
                                                 np.stack([p, q], 1).ravel())), shape=(m, n))
    A = sp.vstack([C, sp.csc_matrix(np.ones((1, n)))]).tocsc()
    return C, A


def run_osqp(L, p, q, eps=1.0, tol=1e-7):
    import osqp

    n, m = L.shape[0], len(p)
    _, A = _baseline_matrices(L, p, q)
    t = time.perf_counter()
    s = osqp.OSQP()
    s.setup(P=sp.triu(L).tocsc(), q=np.zeros(n), A=A, l=np.r_[np.full(m, eps), 0.0],
            u=np.r_[np.full(m, np.inf), 0.0], eps_abs=tol, eps_rel=tol, max_iter=100000,
            polishing=True, verbose=False)
    r = s.solve(raise_error=False)
    return time.perf_counter() - t, r.x, r.info.status


def run_clarabel(L, p, q, eps=1.0):
    import clarabel

    n, m = L.shape[0], len(p)
    C, _ = _baseline_matrices(L, p, q)
    # Clarabel: A x + s = b, s in cones. Gauge row (zero cone) then -C x + s = -eps (s >= 0).
    A = sp.vstack([sp.csc_matrix(np.ones((1, n))), -C]).tocsc()
    b = np.r_[0.0, np.full(m, -eps)]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    t = time.perf_counter()
    solver = clarabel.DefaultSolver(sp.triu(L).tocsc(), np.zeros(n), A, b,
                                    [clarabel.ZeroConeT(1), clarabel.NonnegativeConeT(m)], settings)
    r = solver.solve()
    return time.perf_counter() - t, np.asarray(r.x), str(r.status)


def measure(L, p, q, d, ref_obj):
    d = d - d.mean()
    viol = max(0.0, float((1.0 - (d[p] - d[q])).max()))
    obj = 0.5 * float(d @ (L @ d))
    return viol, abs(obj - ref_obj) / abs(ref_obj), d


def bench_exact(sizes, counts, use_osqp, use_clarabel, repeat=1):
    print("exact QP vs general-purpose QP solvers (turtle drawing, random consistent orders)")
    head = f"{'size':>10} {'m':>4} {'solver':>9} {'time s':>8} {'max viol':>9} " \
           f"{'rel obj diff':>12} {'max |dd|':>9} {'ratio':>7}  note"
    print(head)
    print("-" * len(head))
    for size in sizes:
        for m in counts:
            L, p, q, shape = problem(size, m)
            te = np.inf
            for _ in range(repeat):
                _plan.cache_clear()  # every run pays for its symbolic analysis, as OSQP's does
                _front.cache_clear()
                t = time.perf_counter()
                r = solve_depth_qp(L, p, q, np.ones(m, bool), epsilon=1.0, shape=shape)
                te = min(te, time.perf_counter() - t)
            viol, _, d0 = measure(L, p, q, r.depth, r.objective)
            kkt = max(r.kkt.values())
            print(f"{size:>5}x{size:<4} {m:>4} {'exact':>9} {te:8.2f} {viol:9.1e} {0.0:12.1e} "
                  f"{0.0:9.1e} {1.0:7.1f}  KKT {kkt:.1e}, "
                  + ", ".join(f"{k} {v:.2f}" for k, v in r.timings.items()), flush=True)
            for name, use, fn in (("osqp", use_osqp, run_osqp),
                                  ("clarabel", use_clarabel, run_clarabel)):
                if not use:
                    continue
                try:
                    runs = [fn(L, p, q) for _ in range(repeat)]
                    tb, x, status = min(runs, key=lambda run: run[0])
                except ImportError:
                    print(f"{'':>10} {m:>4} {name:>9}  (not installed)")
                    continue
                if x is None or not np.all(np.isfinite(x)):
                    print(f"{'':>10} {m:>4} {name:>9} {tb:8.2f}  failed ({status})")
                    continue
                v, dobj, d = measure(L, p, q, x, r.objective)
                print(f"{'':>10} {m:>4} {name:>9} {tb:8.2f} {v:9.1e} {dobj:12.1e} "
                      f"{np.abs(d - d0).max():9.1e} {tb / te:7.1f}  {status}", flush=True)


#: Orders added one at a time in the incremental test: a point of the turtle's
#: shell in front of a point of the background, at five places.
EDITS = [((300, 250), (120, 120)), ((280, 300), (60, 420)), ((330, 220), (450, 80)),
         ((260, 260), (470, 460)), ((310, 280), (40, 60))]


def _turtle():
    ann, drawing = load_input(example_path("turtle"))
    return ann, drawing.gray.astype(np.float64)


def bench_fast():
    print()
    print("fast method (turtle 512x512, its 4 orders; then 5 edits, each an order added, "
          "solved, removed, solved)")
    ann, gray = _turtle()
    head = f"{'session':>24} {'first solve':>12} {'prepare':>8} {'add: median':>12} {'max':>7} " \
           f"{'remove: median':>15} {'max':>7} {'target':>7} {'worst / target':>15}"
    print(head)
    print("-" * len(head))
    for name, seeds, prepared in (("scribbles", seed_image(ann), False),
                                  ("scribbles, prepared", seed_image(ann), True),
                                  ("no scribbles", None, False),
                                  ("no scribbles, prepared", None, True)):
        s = DepthSession(gray, seeds=seeds)
        for o in ann.order:
            s.add(o.front, o.back)
        t = time.perf_counter()
        s.solve()
        first = time.perf_counter() - t
        t = time.perf_counter()
        if prepared:
            s.prepare()
        prepare = time.perf_counter() - t
        adds, removes = [], []
        for front, back in EDITS:
            k = s.add(front, back)
            t = time.perf_counter()
            s.solve()
            adds.append(time.perf_counter() - t)
            s.remove(k)
            t = time.perf_counter()
            s.solve()
            removes.append(time.perf_counter() - t)
        worst = max(adds + removes)
        print(f"{name:>24} {first:11.3f}s {prepare if prepared else 0:7.3f}s "
              f"{np.median(adds):11.3f}s {max(adds):6.3f}s "
              f"{np.median(removes):14.3f}s {max(removes):6.3f}s {0.2:6.1f}s {worst / 0.2:15.2f}")


def bench_exact_resolve():
    print()
    print("exact method with the factorization kept (turtle 512x512, its 4 orders; "
          "the same 5 edits)")
    ann, gray = _turtle()
    L = grid_laplacian(*edge_weights(gray)[:2])
    t = time.perf_counter()
    factor = GroundedLaplacian(L, shape=gray.shape)
    first = time.perf_counter() - t
    times = []
    for front, back in EDITS:
        edited = replace(ann, order=ann.order + [Order(front, back, len(ann.order))])
        p, q, ineq, labels = depth_constraints(edited)
        t = time.perf_counter()
        solve_depth_qp(L, p, q, ineq, factor=factor, labels=labels)
        times.append(time.perf_counter() - t)
    print(f"  factorization {first:.3f} s; re-solve with one more order: median "
          f"{np.median(times):.3f} s, worst {max(times):.3f} s")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="512,1024", help="image sides (default 512,1024)")
    ap.add_argument("--constraints", default="10,50", help="constraint counts (default 10,50)")
    ap.add_argument("--no-osqp", action="store_true")
    ap.add_argument("--no-clarabel", action="store_true")
    ap.add_argument("--no-fast", action="store_true")
    ap.add_argument("--repeat", type=int, default=1,
                    help="best of this many runs per solver (default 1; the machine may be noisy)")
    args = ap.parse_args(argv)
    sizes = [int(v) for v in args.sizes.split(",")]
    counts = [int(v) for v in args.constraints.split(",")]
    bench_exact(sizes, counts, not args.no_osqp, not args.no_clarabel, args.repeat)
    if not args.no_fast:
        bench_fast()
        bench_exact_resolve()
    return 0


if __name__ == "__main__":
    sys.exit(main())
