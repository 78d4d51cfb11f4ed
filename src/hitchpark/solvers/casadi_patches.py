"""Every edit of CasADi's generated C, in one place, each guarded by the CasADi versions it was written for.

CasADi writes a whole solver to C (:mod:`.generated`); three edits make that C what hitchpark needs, and a C++
file (``fatrop_warm.cpp``) reaches into fatrop's internals (``#define private public`` around its headers) for
the warm start of its multipliers. These depend on how a CasADi version lays out its code:

- :func:`link_warm_duals`: the generated fatrop solver hands the caller's multipliers to fatrop.
- :func:`link_stagewise`: the generated fatrop solver calls the NLP's functions stage by stage
  (:mod:`.stagewise`) instead of CasADi's, written over the whole horizon.
- :func:`report_sqp_failure`: the generated sqpmethod returns 1 when its iterations did not converge
  (CasADi 3.8's returns 0 however they end).
- :func:`mark_unused_arguments`: the stage functions and the example's plant written for ``hitchpark export``
  mark the arguments they do not use, so that the package compiles under ``-Wall -Wextra -Werror``.

Each checks the layout it edits and gives up (None, or RuntimeError) where it differs; all of them give up on
a CasADi whose major.minor is not in :data:`TESTED_CASADI`, the versions the test suite runs on
(``pyproject.toml`` allows only those). Giving up is safe: fatrop then starts without the multipliers, with
CasADi's functions, and sqpmethod runs in-process, where CasADi reports its status.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import casadi as ca

__all__ = [
    "TESTED_CASADI",
    "WARM_DUALS",
    "casadi_tested",
    "link_stagewise",
    "link_warm_duals",
    "mark_unused_arguments",
    "report_sqp_failure",
    "sqp_edit_text",
]

#: The CasADi versions (major.minor) whose generated code these edits were written for and tested on.
TESTED_CASADI = ("3.8",)


def casadi_tested(version: str | None = None) -> bool:
    """Whether CasADi ``version`` (default: the one imported) is one of :data:`TESTED_CASADI`."""
    parts = (version or str(getattr(ca, "__version__", ""))).split(".")
    return ".".join(parts[:2]) in TESTED_CASADI


#: The generated fatrop solver's side of :data:`WARM_SOURCE`: the caller's multipliers (lam_x0 and lam_g0,
#: which the generated code keeps in ``lam``) in fatrop's layout, as ``casadi_fatrop_solve`` reads fatrop's
#: answer back, the other way.
WARM_DUALS = """
int hitchpark_warm_duals(void* user_data, double* dual) {
  struct casadi_fatrop_data* d = (struct casadi_fatrop_data*) user_data;
  const struct casadi_fatrop_prob* p = d->prob;
  const casadi_real* lam = d->nlp->lam;
  const casadi_int nx = p->nlp->nx;
  const struct FatropOcpCDims* str = fatrop_ocp_c_get_dims(d->solver);
  casadi_int k, i, column;
  for (k=0;k<str->K;++k) {
    column = 0;
    for (i=d->a_ineq_idx[k];i<d->a_ineq_idx[k+1];++i) dual[str->g_ineq_offs[k]+column++] = lam[nx+d->a_ineq[i]];
    for (i=d->x_ineq_idx[k];i<d->x_ineq_idx[k+1];++i) dual[str->g_ineq_offs[k]+column++] = lam[d->x_ineq[i]];
    column = 0;
    for (i=d->a_eq_idx[k];i<d->a_eq_idx[k+1];++i) dual[str->g_offs[k]+column++] = lam[nx+d->a_eq[i]];
    for (i=d->x_eq_idx[k];i<d->x_eq_idx[k+1];++i) dual[str->g_offs[k]+column++] = lam[d->x_eq[i]];
  }
  for (k=0;k<str->K-1;++k) {
    casadi_scaled_copy(-1.0, lam+nx+p->AB[k].offset_r, p->nx[k+1], dual+str->dyn_eq_offs[k]);
  }
  return 0;
}
"""

#: Where the generated C takes :data:`WARM_DUALS` (after the solver's runtime, before its entry point).
_ENTRY = "static int casadi_f0(const casadi_real** arg"


def link_warm_duals(source: str) -> str | None:
    """The C of a generated fatrop solver with :data:`WARM_DUALS`; None where it is not laid out so."""
    if not casadi_tested():
        return None
    needed = ("casadi_fatrop_solve(", "d_nlp->lam[p_nlp->nx+d->a_ineq[i]] = dual_data", "p->AB[k].offset_r")
    if source.count(_ENTRY) != 1 or not all(n in source for n in needed):
        return None
    return source.replace(_ENTRY, WARM_DUALS + "\n" + _ENTRY)


#: A stage-wise function called by the generated solver: its own argument lists and work arrays (of the
#: sizes it asks for; one set per thread), whatever the solver's oracle allots to the function it replaces.
_CALLBACK = """
int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem);
static int {name}_cb(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{
  static _Thread_local const casadi_real* a[{sz_arg}];
  static _Thread_local casadi_real* r[{sz_res}];
  static _Thread_local casadi_int iw_[{sz_iw}];
  static _Thread_local casadi_real w_[{sz_w}];
  int i;
  for (i = 0; i < {n_in}; ++i) a[i] = arg[i];
  for (i = 0; i < {n_out}; ++i) r[i] = res[i];
  return {name}(a, r, iw_, w_, 0);
}}
"""


def link_stagewise(source: str, functions: Mapping[str, ca.Function]) -> str | None:
    """The C of a generated fatrop solver calling ``functions`` (:mod:`.stagewise`) instead of CasADi's.

    The solver's oracle takes each function as a pointer (``p.nlp_hess_l.eval = casadi_f6;``), and the
    gradient it reports at the end is one direct call; each is pointed at a callback of the stage-wise
    function. None when the code is not laid out so (another CasADi): then the solver stays as generated.
    """
    if not casadi_tested():
        return None
    edited, callbacks = source, []
    for key, f in functions.items():
        name = f.name()
        callbacks.append(
            _CALLBACK.format(
                name=name,
                sz_arg=max(f.sz_arg(), 1),
                sz_res=max(f.sz_res(), 1),
                sz_iw=max(f.sz_iw(), 1),
                sz_w=max(f.sz_w(), 1),
                n_in=f.n_in(),
                n_out=f.n_out(),
            )
        )
        if key == "nlp_grad":  # called once, after the iterations: f, g and the gradient in p
            found = re.findall(r"/\* nlp_grad:\(.*\*/\nstatic int (casadi_f\d+)\(", edited)
            if len(found) != 1:
                return None
            call = f"if ({found[0]}(d->arg, d->res, d->iw, d->w, 0)) return 1;"
            if edited.count(call) != 1:
                return None
            edited = edited.replace(call, f"if ({name}_cb(d->arg, d->res, d->iw, d->w, 0)) return 1;")
        else:
            found = re.findall(rf"p\.{key}\.eval = (casadi_f\d+);", edited)
            if len(found) != 1:
                return None
            edited = edited.replace(f"p.{key}.eval = {found[0]};", f"p.{key}.eval = {name}_cb;")
    if edited.count(_ENTRY) != 1:
        return None
    return edited.replace(_ENTRY, "".join(callbacks) + "\n" + _ENTRY)


#: The generated sqpmethod's convergence test (CasADi 3.8): the iterations end on it, on the iteration limit
#: or on a step too small, and the generated function returns 0 after each of the three, whatever
#: ``error_on_fail`` asks (CasADi's own sqpmethod reports the other two as failures).
_SQP_CONVERGED = re.compile(r"if \(iter_count >= 0 && pr_inf < (\S+) && du_inf < (\S+)\) break;")

#: The end of the generated sqpmethod's function: its answer copied out, then success whatever happened.
_SQP_END = "\n  return 0;\n}\n"

#: What :func:`report_sqp_failure` puts in its place, given the convergence test's two tolerances.
_SQP_RETURN = "\n  return pr_inf < {} && du_inf < {} ? 0 : 1;\n}}\n"


def report_sqp_failure(source: str) -> str:
    """The C of a generated sqpmethod solver that returns 1 unless its iterations met the tolerances.

    The main loop is left only by its three tests at the top of an iteration, each after the primal and dual
    infeasibilities of the current iterate are computed: so these meet the tolerances at the end exactly
    when the convergence test ended it. Raises RuntimeError where the code is not laid out so (another
    CasADi): the library is then not built, and the in-process sqpmethod, which reports its status, serves.
    """
    if not casadi_tested():
        raise RuntimeError("generated sqpmethod: not a CasADi this edit was tested on")
    found = list(_SQP_CONVERGED.finditer(source))
    if len(found) != 1:
        raise RuntimeError("generated sqpmethod: no single convergence test to report failures by")
    pr_tol, du_tol = found[0].groups()
    end = source.find(_SQP_END, found[0].end())
    if end < 0:
        raise RuntimeError("generated sqpmethod: the solver's function does not end as expected")
    return source[:end] + _SQP_RETURN.format(pr_tol, du_tol) + source[end + len(_SQP_END) :]


def sqp_edit_text() -> str:
    """The text of the sqpmethod edit: a library built with it is cached under a key that holds it."""
    return _SQP_CONVERGED.pattern + _SQP_END + _SQP_RETURN


def mark_unused_arguments(code: str) -> str:
    """CasADi's functions ``code`` with each function's arguments, and each release's ``mem``, marked used
    (``(void) arg;``): CasADi leaves some unused, which ``-Wextra -Werror`` refuses. Unchanged on a CasADi not in
    :data:`TESTED_CASADI` (the package then builds with warnings)."""
    if not casadi_tested():
        return code
    code = re.sub(
        r"(\(const casadi_real\*\* arg, casadi_real\*\* res, casadi_int\* iw, casadi_real\* w, int mem\) \{\n)",
        r"\1  (void) arg; (void) res; (void) iw; (void) w; (void) mem;\n",
        code,
    )
    return re.sub(r"(_release\(int mem\) \{\n)", r"\1  (void) mem;\n", code)
