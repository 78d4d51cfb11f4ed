"""The NLP's functions of a multiple-shooting transcription, built stage by stage.

An NLP solver calls functions CasADi derives from the whole NLP: the constraints, their Jacobian, the
cost and its gradient, the Lagrangian's gradient and Hessian. Generated to C, each is straight-line code
over the whole horizon (about 2,000 instructions a stage for the full OCP's Hessian); at N = 80 that code
outgrows the processor's instruction caches and a stage costs several times what it costs at N = 10
(``python benchmarks/fatrop_iterations.py full 10 80``). Here each of them is one small function of a
stage, ``(X_k, U_k, step k's parameters and multipliers)``, called once per stage by a function that
assembles the NLP's outputs: the code is the size of a stage whatever N. The expressions are the
transcription's own, so the numbers are the same; :func:`stagewise_functions` checks the outputs'
sparsity and values against CasADi's functions of the solver before they are used.

The layout is :class:`~.transcription.MultipleShooting`'s: ``w = [X_0, U_0, ..., X_N]``, ``p = [x0, P_1..P_N]``
(then the first step's length h0 for an OCP with ``first_step``: stage 0's functions take it, its dynamics
over h0 and its cost weighed by it), ``g = [X_0 - x0, (X_{k+1} - F(X_k, U_k), rows on X_k if k > 0) for k < N,
rows on X_N]``. The Lagrangian
``lam_f f + lam_g' g`` is a sum over stages whose only coupling is the linear ``X_{k+1}`` of each gap: its
Hessian is block diagonal, one block per stage, and the Jacobian's columns of stage k hold only stage k's
rows. So the nonzeros of both, column by column, are those of each stage's block one stage after another.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from .transcription import MultipleShooting, first_step_weight

__all__ = ["ORACLE", "stagewise_functions"]

#: The NLP's functions replaced, by the names CasADi's solvers give them.
ORACLE = ("nlp_hess_l", "nlp_jac_g", "nlp_g", "nlp_f", "nlp_grad_f", "nlp_grad")


def _block(sparsity: ca.Sparsity, first: int, size: int) -> ca.Sparsity:
    """The sparsity of rows and columns ``first .. first + size`` of ``sparsity``."""
    index = list(range(first, first + size))
    out = sparsity.sub(index, index, False)
    return out[0] if isinstance(out, tuple) else out


def _nonzeros(matrix: ca.SX) -> ca.SX:
    return matrix.nz[:] if matrix.nnz() else ca.SX(0, 1)


def stagewise_functions(transcription: Any, solver: ca.Function, prefix: str) -> dict[str, ca.Function] | None:
    """The :data:`ORACLE` functions of ``solver`` (an ``nlpsol`` of ``transcription.nlp``), stage by stage.

    Named ``prefix`` + the function's name, with the inputs, outputs and sparsity of CasADi's. None when
    the transcription is not multiple shooting, has path constraints (they may depend on k), or the
    functions do not give what CasADi's give at a random point (then the caller keeps CasADi's).
    """

    pr = transcription.problem
    if not isinstance(transcription, MultipleShooting) or pr.path_constraints:
        return None
    N, nx, nu, n_p = pr.horizon, pr.n_x, pr.n_u, pr.n_p
    stride = nx + nu
    hess_sp = solver.get_function("nlp_hess_l").sparsity_out(1)
    jac_sp = solver.get_function("nlp_jac_g").sparsity_out(1)

    # --- one stage, in SX ---------------------------------------------------------------------------
    X, U, P = ca.SX.sym("X", nx), ca.SX.sym("U", nu), ca.SX.sym("P", n_p)
    lam_f, lam_gap = ca.SX.sym("lam_f"), ca.SX.sym("lam_gap", nx)
    row_list = pr.step_rows(X, P)[0]
    rows = ca.vertcat(*row_list) if row_list else ca.SX(0, 1)
    n_rows = rows.numel()
    lam_rows = ca.SX.sym("lam_rows", n_rows)
    XU = ca.vertcat(X, U)
    F = pr.discrete_dynamics(X, U)  # Eq. (48)
    stage_cost, terminal_cost = pr.stage_cost(X, U, P), pr.terminal_cost(X, P)
    # Stage 0 over the first step's length H where the OCP makes it a parameter (p's last), its cost weighed so.
    H = ca.SX.sym("H")
    h_in = [H] if pr.first_step else []
    F0 = pr.discrete_dynamics(X, U, H) if pr.first_step else F
    cost0 = first_step_weight(pr, H) * stage_cost if pr.first_step else stage_cost
    # Each stage's share of lam_f f + lam_g' g, without the X_{k+1} of its gap (linear: added below).
    initial = lam_f * cost0 - ca.dot(lam_gap, F0)  # stage 0: no rows on X_0 (it is given)
    middle = lam_f * stage_cost - ca.dot(lam_gap, F) + ca.dot(lam_rows, rows)
    last = lam_f * terminal_cost + ca.dot(lam_rows, rows)

    def hessian(lagrangian: ca.SX, of: ca.SX, at: int) -> ca.SX:
        return _nonzeros(ca.project(ca.hessian(lagrangian, of)[0], _block(hess_sp, at, of.numel())))

    def fn(name: str, inputs: list[ca.SX], outputs: list[ca.SX]) -> ca.Function:
        return ca.Function(f"{prefix}{name}", inputs, outputs)

    at_middle = stride * min(1, N - 1)  # a middle stage's block (stage 0's when N = 1: then unused)
    hess_0 = fn("hess_0", [X, U, P, lam_f, lam_gap, *h_in], [ca.gradient(initial, XU), hessian(initial, XU, 0)])
    hess_k = fn(
        "hess_k", [X, U, P, lam_f, lam_gap, lam_rows], [ca.gradient(middle, XU), hessian(middle, XU, at_middle)]
    )
    hess_n = fn("hess_n", [X, P, lam_f, lam_rows], [ca.gradient(last, X), hessian(last, X, N * stride)])
    grad_0 = fn(
        "grad_0",
        [X, U, P, lam_f, lam_gap, *h_in],
        [ca.gradient(initial, XU), ca.gradient(initial, P), *[ca.gradient(initial, h) for h in h_in]],
    )
    grad_k = fn("grad_k", [X, U, P, lam_f, lam_gap, lam_rows], [ca.gradient(middle, XU), ca.gradient(middle, P)])
    grad_n = fn("grad_n", [X, P, lam_f, lam_rows], [ca.gradient(last, X), ca.gradient(last, P)])
    # The Jacobian's rows of stage k's columns, in g's order: the gap before (X_k), its own gap, its rows.
    jac_0 = fn("jac_0", [X, U, P, *h_in], [F0, _nonzeros(ca.jacobian(ca.vertcat(X, -F0), XU))])
    jac_k = fn("jac_k", [X, U, P], [F, rows, _nonzeros(ca.jacobian(ca.vertcat(X, -F, rows), XU))])
    jac_n = fn("jac_n", [X, P], [rows, _nonzeros(ca.jacobian(ca.vertcat(X, rows), X))])
    g_0 = fn("g_0", [X, U, P, *h_in], [F0])
    g_k = fn("g_k", [X, U, P], [F, rows])
    g_n = fn("g_n", [X, P], [rows])
    cost_0 = fn("cost_0", [X, U, P, *h_in], [cost0, ca.gradient(cost0, XU)])
    cost_k = fn("cost_k", [X, U, P], [stage_cost, ca.gradient(stage_cost, XU)])
    cost_n = fn("cost_n", [X, P], [terminal_cost, ca.gradient(terminal_cost, X)])

    # --- the whole NLP, in MX: a call per stage -----------------------------------------------------
    n_w, n_par, n_g = (int(transcription.nlp[k].numel()) for k in ("x", "p", "g"))
    w, p = ca.MX.sym("x", n_w), ca.MX.sym("p", n_par)
    lf, lg = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_g)
    xs = [w[k * stride : k * stride + nx] for k in range(N + 1)]
    us = [w[k * stride + nx : (k + 1) * stride] for k in range(N)]
    # Step k's parameters (step 1's for stage 0, as the transcription's cost takes them).
    ps = [p[nx + (max(k, 1) - 1) * n_p : nx + max(k, 1) * n_p] for k in range(N + 1)]
    h_arg = [p[n_par - 1]] if pr.first_step else []  # the first step's length
    grad_h: list[ca.MX] = []
    gap_at, rows_at, at = [], {}, nx  # where each gap's and each step's rows start in g
    for k in range(N):
        gap_at.append(at)
        at += nx
        if k > 0:
            rows_at[k] = at
            at += n_rows
    rows_at[N] = at
    if at + n_rows != n_g:
        return None
    lam_init = lg[:nx]
    lam_gaps = [lg[a : a + nx] for a in gap_at]
    lam_row = {k: lg[a : a + n_rows] for k, a in rows_at.items()}

    def before(k: int) -> ca.MX:
        """The multipliers of the row that holds X_k linearly: X_0 = x0, or gap k - 1."""
        return lam_init if k == 0 else lam_gaps[k - 1]

    grad_x, hess_nz, grad_p = [], [], [ca.MX(0, 1)] * (N + 1)
    for k in range(N):
        args: tuple[ca.MX, ...]
        if k == 0:
            args = (xs[0], us[0], ps[0], lf, lam_gaps[0], *h_arg)
            (gk, hk), (_, dp, *grad_h) = hess_0(*args), grad_0(*args)
        else:
            args = (xs[k], us[k], ps[k], lf, lam_gaps[k], lam_row[k])
            (gk, hk), (_, dp) = hess_k(*args), grad_k(*args)
        grad_x.append(gk + ca.vertcat(before(k), ca.MX(nu, 1)))
        hess_nz.append(hk)
        j = max(k, 1)
        grad_p[j] = dp if grad_p[j].numel() == 0 else grad_p[j] + dp
    gn, hn = hess_n(xs[N], ps[N], lf, lam_row[N])
    grad_x.append(gn + before(N))
    hess_nz.append(hn)
    dp_n = grad_n(xs[N], ps[N], lf, lam_row[N])[1]
    grad_p[N] = dp_n if grad_p[N].numel() == 0 else grad_p[N] + dp_n
    grad_gamma_x = ca.vertcat(*grad_x)
    # x0 enters only X_0 - x0: its gradient is -lam_init.
    grad_gamma_p = ca.vertcat(-lam_init, *grad_p[1:], *grad_h)

    g_parts, jac_nz = [xs[0] - p[:nx]], []
    gaps, step_rows = [], {}
    for k in range(N):
        if k == 0:
            fk, jk = jac_0(xs[0], us[0], ps[0], *h_arg)
        else:
            fk, rk, jk = jac_k(xs[k], us[k], ps[k])
            step_rows[k] = rk
        gaps.append(fk)
        jac_nz.append(jk)
    rn, jn = jac_n(xs[N], ps[N])
    jac_nz.append(jn)
    for k in range(N):
        g_parts.append(xs[k + 1] - gaps[k])
        if k > 0:
            g_parts.append(step_rows[k])
    g_parts.append(rn)

    g_only = [xs[0] - p[:nx]]
    for k in range(N):
        if k == 0:
            g_only.append(xs[1] - g_0(xs[0], us[0], ps[0], *h_arg))
            continue
        fk, rk = g_k(xs[k], us[k], ps[k])
        g_only.append(xs[k + 1] - fk)
        g_only.append(rk)
    g_only.append(g_n(xs[N], ps[N]))
    g_expr = ca.vertcat(*g_only)

    costs, cost_grads = [], []
    for k in range(N):
        ck, dk = cost_0(xs[0], us[0], ps[0], *h_arg) if k == 0 else cost_k(xs[k], us[k], ps[k])
        costs.append(ck)
        cost_grads.append(dk)
    cn, dn = cost_n(xs[N], ps[N])
    f_expr = ca.sum1(ca.vertcat(*costs, cn))

    def whole(name: str, inputs: list[ca.MX], outputs: list[ca.MX], like: str) -> ca.Function:
        reference = solver.get_function(like)
        return ca.Function(
            f"{prefix}{name}",
            inputs,
            outputs,
            [reference.name_in(i) for i in range(reference.n_in())],
            [reference.name_out(i) for i in range(reference.n_out())],
        )

    functions = {
        "nlp_hess_l": whole(
            "hess_l", [w, p, lf, lg], [grad_gamma_x, ca.MX(hess_sp, ca.vertcat(*hess_nz))], "nlp_hess_l"
        ),
        "nlp_jac_g": whole("jac_g", [w, p], [ca.vertcat(*g_parts), ca.MX(jac_sp, ca.vertcat(*jac_nz))], "nlp_jac_g"),
        "nlp_g": whole("g", [w, p], [g_expr], "nlp_g"),
        "nlp_f": whole("f", [w, p], [f_expr], "nlp_f"),
        "nlp_grad_f": whole("grad_f", [w, p], [ca.vertcat(*cost_grads, dn)], "nlp_grad_f"),
        "nlp_grad": whole("grad", [w, p, lf, lg], [f_expr, g_expr, grad_gamma_x, grad_gamma_p], "nlp_grad"),
    }
    return functions if _agree(solver, functions) else None


def _agree(solver: ca.Function, functions: dict[str, ca.Function], tolerance: float = 1e-9) -> bool:
    """The functions give CasADi's sparsity and numbers at a random point (relative to their size)."""
    rng = np.random.default_rng(0)
    for name, mine in functions.items():
        theirs = solver.get_function(name)
        if mine.n_in() != theirs.n_in() or mine.n_out() != theirs.n_out():
            return False
        args = [rng.uniform(-0.5, 0.5, theirs.size_in(i)) for i in range(theirs.n_in())]
        for a, b in zip(theirs(*args) if theirs.n_out() > 1 else [theirs(*args)], _outputs(mine, args), strict=True):
            if a.sparsity() != b.sparsity():
                return False
            ours, casadis = np.asarray(b.nonzeros()), np.asarray(a.nonzeros())
            scale = 1.0 + float(np.max(np.abs(casadis), initial=0.0))
            if float(np.max(np.abs(ours - casadis), initial=0.0)) > tolerance * scale:
                return False
    return True


def _outputs(function: ca.Function, args: list[np.ndarray]) -> list[ca.DM]:
    out = function(*args)
    return list(out) if function.n_out() > 1 else [out]
