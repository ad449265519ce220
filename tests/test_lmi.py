"""satfmu.synthesis.core.lmi: affine matrix expressions against numpy, LMI programs against closed forms."""

import numpy as np
import pytest
import scipy.linalg as sla

from satfmu.synthesis.core import conic, lmi


def test_operations_match_numpy_at_random_values():
    """Every operation, evaluated at random variable values, equals numpy's on the values
    (exact up to rounding: 1e-12 on entries of order 10)."""
    rng = np.random.default_rng(0)
    prog = lmi.LMIProgram()
    Y, W = prog.variable((3, 3), symmetric=True), prog.variable((2, 3))
    g = prog.variable()
    A, B, M = rng.normal(size=(3, 3)), rng.normal(size=(3, 2)), rng.normal(size=(4, 3))
    x = rng.normal(size=prog.n)

    def value(e):
        return (e.coef[:, 0] + e.coef[:, 1:] @ x[e.vars]).reshape(e.shape)

    Yv, Wv, gv = value(Y), value(W), value(g)[0, 0]
    assert np.allclose(Yv, Yv.T, atol=0)
    L = A @ Y + Y @ A.T + B @ W + W.T @ B.T
    assert np.allclose(value(L), A @ Yv + Yv @ A.T + B @ Wv + Wv.T @ B.T, atol=1e-12)
    blk = lmi.bmat([[L, M.T], [M, -g * np.eye(4)]])
    ref = np.block([[A @ Yv + Yv @ A.T + B @ Wv + Wv.T @ B.T, M.T], [M, -gv * np.eye(4)]])
    assert np.allclose(value(blk), ref, atol=1e-12)
    assert np.allclose(value(lmi.vstack([Y, W, np.ones((1, 3))])), np.vstack([Yv, Wv, np.ones((1, 3))]), atol=0)
    assert np.allclose(value((2.0 - Y) / 4 + 0.5 * Y.T), (2.0 - Yv) / 4 + 0.5 * Yv.T, atol=1e-15)
    assert np.allclose(value(np.float64(3.0) * W - W @ np.eye(3)), 2 * Wv, atol=1e-14)


def test_products_of_expressions_and_shape_errors_are_refused():
    prog = lmi.LMIProgram()
    Y = prog.variable((2, 2), symmetric=True)
    g = prog.variable()
    with pytest.raises(lmi.LMIError, match="not affine"):
        Y @ Y
    with pytest.raises(lmi.LMIError, match="not affine"):
        g * Y
    with pytest.raises(lmi.LMIError, match="cannot add"):
        Y + np.ones((3, 3))
    with pytest.raises(lmi.LMIError, match="cannot multiply"):
        np.ones((3, 3)) @ Y
    with pytest.raises(lmi.LMIError, match="block row"):
        lmi.bmat([[Y, np.zeros((2, 1))], [np.zeros((1, 3))]])
    with pytest.raises(lmi.LMIError, match="square"):
        prog.variable((2, 3), symmetric=True)
    with pytest.raises(lmi.LMIError, match="square"):
        prog.add_psd(prog.variable((2, 3)))
    with pytest.raises(lmi.LMIError, match="solve first"):
        prog.value(Y)
    with pytest.raises(lmi.LMIError, match="no constraints"):
        prog.solve(g)


def test_lyapunov_program_matches_scipy():
    """min trace P s.t. A^T P + P A <= -I: P is the Lyapunov solution (the constraint is active),
    to the solver's accuracy (1e-6 relative, Clarabel's 1e-8 tolerances on this scale)."""
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 4)) - 3 * np.eye(4)
    prog = lmi.LMIProgram()
    P = prog.variable((4, 4), symmetric=True)
    prog.add_psd(-(A.T @ P + P @ A) - np.eye(4))
    sol = prog.solve(_trace(P))
    assert sol.solved
    ref = sla.solve_continuous_lyapunov(A.T, -np.eye(4))
    assert np.allclose(prog.value(P), ref, rtol=1e-6, atol=1e-8)
    assert sol.objective == pytest.approx(np.trace(ref), rel=1e-7)


def _trace(P):
    n = P.shape[0]
    return sum(np.eye(n)[[i]] @ P @ np.eye(n)[:, [i]] for i in range(n))


def test_maximize_and_scalar_inequality():
    """max t s.t. [[1, t], [t, 1]] >= 0 and t <= 0.5: t = 0.5 (the scalar bound active, 1e-7)."""
    prog = lmi.LMIProgram()
    t = prog.variable()
    prog.add_psd(lmi.bmat([[np.ones((1, 1)), t], [t, np.ones((1, 1))]]))
    prog.add_nonneg(0.5 - t)
    sol = prog.solve(t, maximize=True)
    assert sol.solved and prog.value(t)[0, 0] == pytest.approx(0.5, abs=1e-7)


def test_dual_weights_mark_the_binding_lmis():
    """min tr P s.t. P >= diag(1, 2) (binds: its dual is I, Frobenius norm sqrt 2) and P >= 0.5 I
    (slack 0.5: dual 0 to the solver's 1e-8 accuracy); untagged cones are not reported."""
    prog = lmi.LMIProgram()
    P = prog.variable((2, 2), symmetric=True)
    with pytest.raises(lmi.LMIError, match="solve first"):
        prog.dual_weights()
    prog.add_psd(P - np.diag([1.0, 2.0]), tag="tight")
    prog.add_psd(P - 0.5 * np.eye(2), tag="loose")
    prog.add_psd(P + np.eye(2))
    e1, e2 = np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]])
    prog.add_nonneg(10.0 - e1 @ P @ e1.T)  # a scalar row first: the cones' rows start after it
    assert prog.solve(e1 @ P @ e1.T + e2 @ P @ e2.T).solved
    w = prog.dual_weights()
    assert set(w) == {"tight", "loose"}
    assert w["tight"] == pytest.approx(np.sqrt(2.0), rel=1e-6) and w["loose"] < 1e-6


def test_infeasible_program_is_reported():
    """P >= I and P <= 0 has no solution: Clarabel's certificate, no values."""
    prog = lmi.LMIProgram()
    P = prog.variable((2, 2), symmetric=True)
    prog.add_psd(P - np.eye(2))
    prog.add_psd(-P)
    sol = prog.solve()
    assert not sol.solved and sol.outcome.status == "infeasible"
    with pytest.raises(lmi.LMIError):
        prog.value(P)


def test_size_guard_refuses_a_program_before_the_solver():
    """The estimate is sum d^2 + rows x variables entries (exact integers here), and a program
    past ``max_bytes`` is refused while it is built, naming its size; the default limit is half
    the machine's memory, so every program of the test suite passes it."""
    prog = lmi.LMIProgram(max_bytes=10**9)
    Y = prog.variable((4, 4), symmetric=True)  # 10 variables
    prog.add_psd(Y)  # 10 svec rows
    prog.add_nonneg(np.ones((4, 1)) - Y @ np.ones((4, 1)))  # 4 scalar rows
    assert prog.solver_bytes() == lmi.BYTES_PER_ENTRY * (10 * 10 + (10 + 4) * 10)
    small = lmi.LMIProgram(max_bytes=lmi.BYTES_PER_ENTRY * 500)
    X = small.variable((6, 6), symmetric=True)  # 21 variables, 21 rows: 441 + 441 > 500
    with pytest.raises(lmi.ProgramTooLargeError, match=r"1 PSD cones up to order 6, 21 variables.*> max_bytes"):
        small.add_psd(X)
    assert lmi.LMIProgram().max_bytes == lmi.MAX_SOLVER_BYTES >= 2**30


def _psd_program() -> tuple[lmi.LMIProgram, lmi.Affine]:
    """min trace Y s.t. Y >= A (A = diag(1, 2, 3) plus a coupling): optimum trace A = 6."""
    prog = lmi.LMIProgram()
    Y = prog.variable((3, 3), symmetric=True)
    A = np.diag([1.0, 2.0, 3.0]) + 0.1 * (np.ones((3, 3)) - np.eye(3))
    prog.add_psd(Y - A)
    return prog, _trace(Y)


@pytest.mark.skipif(conic._address_space() is None, reason="isolated solves need /proc (Linux)")
def test_large_programs_solve_in_a_capped_child(monkeypatch):
    """Above ISOLATE_BYTES a program is solved in a child interpreter capped at max_bytes: the same
    answer as in the process (the same solver on the same arrays: to 1e-12), and running out of
    memory there is ProgramTooLargeError instead of the Rust abort of the whole process (an
    order-50 cone puts a dense 1275 x 1275 block, 13 MB, into Clarabel's KKT system: a cap of
    4 MB above the caller cannot hold it). A bad setting still raises in the caller. The caller
    first solves six order-8 cones, which starts Clarabel's thread pool in it (after that, a forked
    child deadlocked in a script, not always under pytest: the child is now a new interpreter)."""
    pool = lmi.LMIProgram()
    Y = pool.variable((8, 8), symmetric=True)
    for B in np.random.default_rng(0).standard_normal((6, 8, 8)):
        pool.add_psd(Y - B @ B.T)
    assert pool.solve(_trace(Y)).solved
    here, obj = _psd_program()
    x_here = here.solve(obj).x
    monkeypatch.setattr(lmi, "ISOLATE_BYTES", 0)
    child, obj = _psd_program()
    sol = child.solve(obj)
    assert sol.solved and sol.objective == pytest.approx(6.0, abs=1e-6)
    np.testing.assert_allclose(sol.x, x_here, rtol=0, atol=1e-12)
    starved = lmi.LMIProgram()
    Y = starved.variable((50, 50), symmetric=True)
    starved.add_psd(Y - np.eye(50))
    starved.max_bytes = 2**22  # lowered after the build: the cap of the child
    with pytest.raises(lmi.ProgramTooLargeError, match="ran out of memory in the solver"):
        starved.solve(_trace(Y))
    with pytest.raises(TypeError, match="unrecognized solver setting"):
        conic.solve_clarabel(child._problem(obj), memory_limit=2**30, no_such_setting=1)
