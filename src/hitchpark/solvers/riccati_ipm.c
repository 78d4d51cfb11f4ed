/* A primal-dual interior-point method for a multiple-shooting OCP, its Newton steps by a Riccati recursion.
 *
 * hitchpark's own structured solver (the route ``riccati_c``, hitchpark.solvers.riccati). The NLP is the
 * transcription's (hitchpark.solvers.stagewise): w = [X_0, U_0, ..., X_N], g = [X_0 - x0, then for
 * k < N the gap X_{k+1} - F_k(X_k, U_k) and, for k > 0, the rows on X_k; then the rows on X_N]. Its
 * functions come stage by stage from CasADi's generated C (HP_LIN*: cost, gradient, dynamics and their
 * Jacobian, rows and theirs, the Lagrangian's Hessian block; HP_EV*: cost, dynamics and rows alone).
 *
 * The method is the classic one (Nocedal and Wright, ch. 19; IPOPT's paper, Waechter and Biegler 2006):
 * each one-sided constraint c_j(w) >= 0 (a finite bound of a row or a variable) gets a slack s_j > 0 and
 * a multiplier z_j > 0. From a warm start (the caller's multipliers) the barrier parameter mu stays at
 * HP_MU (the solves begin near the optimum; the tolerance is met at mu = tol / 10); from a cold start it
 * begins at HP_MU_COLD and comes down to HP_MU by IPOPT's monotone rule (a solve far from the optimum
 * with mu already tiny hugs the bounds and can stall). Each Newton step of the perturbed KKT conditions
 * eliminates slacks and their multipliers stage by stage:
 *   (H_k + Jc_k' Sigma_k Jc_k) is stage k's block (Sigma = z / s), and
 *   q_k = grad_k - Jc_k' (mu / s - Sigma (c - s)) its gradient (mu: each constraint's target of s z),
 * which leaves an equality-constrained QP with the OCP's structure, solved by the Riccati recursion
 * (Rawlings, Mayne and Diehl, "Model Predictive Control", 2nd ed., section 8.8.3). A component of X_0 may
 * be freed from x0 (its row's bounds both infinite; a stage's free-steer problem, the wheels' angle chosen
 * standing still, within its variable bounds): its step is the one that minimizes the cost to go P_0, p_0
 * given the fixed ones. The reduced Hessian is positive definite on the dynamics' null space exactly when
 * every R_bar_k is (X_0 fixed), and P_0 on the free components of X_0, checked by their Cholesky factors;
 * where one is not, delta I is added to every block and the recursion is redone (IPOPT's inertia
 * correction). At HP_MU, with HP_CORRECTOR, the step takes Mehrotra's corrector (Nocedal
 * and Wright, section 14.2): the same factors solve again for the complementarity s z -> mu - ds dz of the
 * step just found, which it would miss by that product; the corrected step is kept where the fraction to
 * the boundary leaves it at least as long and the line search takes it whole, else the step uncorrected is
 * searched. A constraint coming active then closes most of its slack in one step, not a part each step (a
 * fifth fewer iterations on the recorded obstacle problems, docs/history/speed-notebook.md). The step is cut by the
 * fraction to the boundary and then by IPOPT's backtracking filter line search (section 2.3 of the paper;
 * its constants), on the residuals' l1 norm theta and the barrier function phi = f - mu sum(log s), with
 * one second-order correction of a rejected full step (the Maratos effect: near the optimum a full step of
 * a nonlinear model raises the residuals it should remove). No restoration phase: where the filter accepts
 * no step, a backtracking search on the l1 merit function phi + nu theta takes its place (nu above every
 * multiplier), and the filter starts anew; where that finds no step above HP_MIN_STEP the solve fails (the
 * caller's fallback then answers).
 *
 * All data of a stage lie together (struct hp_stage) in the caller's work array: at N = 80 an iteration
 * walks through 0.91 MB (the obstacle OCP), which a core's second-level cache holds.
 *
 * The solver is one unit of C in four files, in this order: this one (the sizes, a stage's data, its functions'
 * evaluation), riccati_ipm_newton.inc (the Newton step), riccati_ipm_search.inc (the step's length) and
 * riccati_ipm_solve.inc (the solve). hitchpark.solvers.riccati.riccati_source joins them; the exported package
 * holds the joined text as src/riccati_ipm.inc.
 *
 * Before this file come the definitions of HP_N, HP_NX, HP_NU, HP_NR (rows a stage), HP_NP (parameters a
 * stage), HP_H0 (1: p ends with the first step's length, which stage 0's functions take), HP_TOL, HP_MU,
 * HP_MAX_ITER, HP_BOUND_PUSH (the least slack at the start), HP_CORRECTOR (1: Mehrotra's corrector), the
 * functions' names and their work sizes (hitchpark.solvers.riccati); optionally HP_WARM_ITER and HP_WARM_WHOLE (below).
 *
 * HP_WARM_ITER > 0 (opt-in; undefined or 0: off): a real-time-iteration-like cap on a warm-started solve. After
 * that many Newton steps of a solve from the caller's multipliers, the iterate is the answer, returned as a
 * success (code 0) whether or not it meets the tolerance; its cost, dynamics and rows come from the accepted
 * trial's evaluation, so the capped solve does not linearize again at its last point. A cold start keeps
 * HP_MAX_ITER.
 *
 * HP_WARM_WHOLE 1 (with HP_WARM_ITER; opt-in): the cap answers only a step taken whole, the primal and the dual
 * step both of length 1: the iterate is then the Newton step of the linearization, as a real-time iteration's
 * QP answers it. A step the fraction to the boundary or the line search cut short (a constraint coming active,
 * a linearization that did not hold) is not an answer: the solve goes on, to the next step taken whole or to the
 * tolerance, whichever comes first (a speed held on its bound is then released in one sample, not over many).
 */

/* At -O3 a step takes a third less time than at the -O1 of hitchpark's own cache (the same bits): GCC takes that level
 * here whatever the build asks. -DHP_OPTIMIZE_AS_BUILT keeps the build's own (-Os for a small flash, -O0 for a
 * sanitized build, which then compiles in an eighth of the time). No level reorders a floating-point operation. */
#if defined(__GNUC__) && !defined(__clang__) && !defined(HP_OPTIMIZE_AS_BUILT)
#pragma GCC optimize("O3")
#endif
#include <math.h>
#include <string.h>
#include <stdint.h>

#ifndef HP_WARM_ITER
#define HP_WARM_ITER 0 /* off: every solve has HP_MAX_ITER iterations */
#endif
#ifndef HP_WARM_WHOLE
#define HP_WARM_WHOLE 0 /* the cap answers any step */
#endif
#define HP_MIN_STEP 1e-12 /* the least step the line search tries */
#define HP_MU_COLD 0.1    /* mu from a cold start (IPOPT's mu_init), brought down to HP_MU */
#define HP_PUSH_COLD 1e-2 /* the least slack from a cold start, relative to max(1, |bound|) (IPOPT's bound_push) */

#define HP_NV (HP_NX + HP_NU)
#define HP_NC (2 * HP_NR + 2 * HP_NV) /* one-sided constraints a stage: rows low, high; variables low, high */
#define HP_NRA (HP_NR > 0 ? HP_NR : 1) /* an array's length for the rows (none: 1) */
#define HP_NW ((HP_N + 1) * HP_NV - HP_NU)               /* the NLP's variables */
#define HP_NG (HP_NX + HP_N * HP_NX + HP_N * HP_NR)        /* and constraints */

typedef casadi_real real;

/* fmax and fmin, inline: GCC calls libm's for each (maxsd alone differs on a NaN). A NaN argument loses, and of
 * two equal arguments the second is returned, as glibc's on x86-64 (the bits are the same as before). */
static real hp_fmax(real a, real b) { return a > b || b != b ? a : b; }
static real hp_fmin(real a, real b) { return a < b || b != b ? a : b; }

struct hp_stage {
  real w[HP_NV], dw[HP_NV], wt[HP_NV];       /* X_k (and U_k), its step, the trial point */
  real bound[HP_NC];                         /* each constraint's bound (low: lb, high: ub) */
  signed char on[HP_NC];                     /* 1: a finite bound, a constraint */
  real c[HP_NC], s[HP_NC], z[HP_NC];         /* constraint values, slacks, multipliers */
  real ds[HP_NC], dz[HP_NC], st[HP_NC], ct[HP_NC];
  real tgt[HP_NC];                           /* the step's target of s z: mu, less the corrector's ds dz */
  real sig[HP_NC], ts[HP_NC];                /* z / s (this iteration's), tgt / s (hp_gradients') */
  real lg[HP_NC], lgt[HP_NC];                /* log s (once hp_work.lg_ok), log st (the last trial's) */
  real lam[HP_NX], lam_new[HP_NX];           /* multipliers of the rows defining X_k (X_0 = x0, gap k - 1) */
  real cost, cost_t;                         /* stage cost at w and at wt */
  real grad[HP_NV];                          /* cost gradient */
  real F[HP_NX], Ft[HP_NX];                  /* F_k(X_k, U_k) at w and at wt */
  real AB[HP_NX * HP_NV];                    /* dF/d(X, U), column-major */
  real rows[HP_NRA], rows_t[HP_NRA];
  real J[HP_NRA * HP_NX];                    /* d rows / dX, column-major */
  real hess[HP_NV * HP_NV];                  /* the Lagrangian's Hessian block */
  real Ht[HP_NV * HP_NV], qt[HP_NV];         /* the barrier's: see the top */
  real P[HP_NX * HP_NX], p[HP_NX];           /* cost to go from X_k */
  real L[HP_NU * HP_NU], K[HP_NU * HP_NX], kk[HP_NU], rbar[HP_NU];
  real b[HP_NX];                             /* F_k - X_{k+1} (or its correction) */
};

struct hp_work {
  struct hp_stage st[HP_N + 1];
  const real* arg[HP_SZ_ARG];
  real* res[HP_SZ_RES];
  casadi_int iw[HP_SZ_IW];
  real w[HP_SZ_W];
  real e0[HP_NX];      /* x0 - X_0 */
  signed char free0[HP_NX]; /* 1: X_0's component free of x0 (its row's bounds infinite), bounded as a variable */
  int n_free;
  real L0[HP_NX * HP_NX]; /* the factor of P_0 on the free components */
  real theta_max, theta_min;               /* the filter's bounds on theta */
  real filter_theta[HP_MAX_ITER + 1], filter_phi[HP_MAX_ITER + 1];
  int filter_size;
  real delta_last;     /* the last inertia correction */
  real mu;             /* the barrier parameter */
  int lg_ok;           /* every stage's lg holds log s */
  int iterations;
  int capped;          /* 1: the last solve answered at HP_WARM_ITER, its tolerance not checked */
};

int HP_LIN0(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HP_LINK(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HP_LINN(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HP_EV0(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HP_EVK(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HP_EVN(const real** arg, real** res, casadi_int* iw, real* w, int mem);

static int hp_nv(int k) { return k < HP_N ? HP_NV : HP_NX; }
static int hp_has_rows(int k) { return k > 0 && HP_NR > 0; }

/* Where stage k's gap (X_{k+1} - F_k) and rows start in g. */
static int hp_gap_at(int k) { return HP_NX + k * HP_NX + (k > 0 ? (k - 1) * HP_NR : 0); }
static int hp_rows_at(int k) { return k < HP_N ? hp_gap_at(k) + HP_NX : HP_NX + HP_N * HP_NX + (HP_N - 1) * HP_NR; }

static const real* hp_params(const real* p, int k) { return p + HP_NX + (k > 0 ? k - 1 : 0) * HP_NP; }

/* The multipliers of the rows a stage's Hessian takes: -z_low + z_high. */
static void hp_row_duals(const struct hp_stage* s, real* out) {
  int i;
  for (i = 0; i < HP_NR; ++i) out[i] = (s->on[i] ? -s->z[i] : 0.0) + (s->on[HP_NR + i] ? s->z[HP_NR + i] : 0.0);
}

/* 1: every v[i] finite (its exponent not all ones). The exponent plus one reaches the sign bit where it is all
 * ones; an OR of those over v, which the compiler vectorizes (a loop of isfinite with an early exit it does not). */
static int hp_finite(const real* v, int n) {
  int i;
  if (sizeof(real) == sizeof(uint64_t)) {
    uint64_t bad = 0, b;
    for (i = 0; i < n; ++i) {
      memcpy(&b, v + i, sizeof(b));
      bad |= (b & 0x7ff0000000000000ULL) + (1ULL << 52);
    }
    return !(bad >> 63);
  }
  for (i = 0; i < n; ++i) if (!isfinite(v[i])) return 0;
  return 1;
}

/* Stage k's cost, dynamics and rows at w (trial = 0) or at wt (trial = 1). 0: finite. */
static int hp_eval(struct hp_work* m, int k, const real* p, int trial) {
  struct hp_stage* s = &m->st[k];
  const real* w = trial ? s->wt : s->w;
  real* cost = trial ? &s->cost_t : &s->cost;
  real* F = trial ? s->Ft : s->F;
  real* rows = trial ? s->rows_t : s->rows;
  const real* P = hp_params(p, k);
  if (k == 0) {
    m->arg[0] = w; m->arg[1] = w + HP_NX; m->arg[2] = P;
#if HP_H0
    m->arg[3] = p + HP_NX + HP_N * HP_NP;
#endif
    m->res[0] = cost; m->res[1] = F;
    if (HP_EV0(m->arg, m->res, m->iw, m->w, 0)) return 1;
  } else if (k < HP_N) {
    m->arg[0] = w; m->arg[1] = w + HP_NX; m->arg[2] = P;
    m->res[0] = cost; m->res[1] = F; m->res[2] = rows;
    if (HP_EVK(m->arg, m->res, m->iw, m->w, 0)) return 1;
  } else {
    m->arg[0] = w; m->arg[1] = P;
    m->res[0] = cost; m->res[1] = rows;
    if (HP_EVN(m->arg, m->res, m->iw, m->w, 0)) return 1;
  }
  if (!isfinite(*cost)) return 1;
  if (k < HP_N && !hp_finite(F, HP_NX)) return 1;
  if (hp_has_rows(k) && !hp_finite(rows, HP_NR)) return 1;
  return 0;
}

/* Stage k's derivatives at w, its Hessian at the current multipliers. 0: finite. */
static int hp_linearize(struct hp_work* m, int k, const real* p) {
  struct hp_stage* s = &m->st[k];
  const real* P = hp_params(p, k);
  real lam_rows[HP_NRA];
  const real* lam_gap = k < HP_N ? m->st[k + 1].lam : 0;
  int nv = hp_nv(k);
  hp_row_duals(s, lam_rows);
  if (k == 0) {
    m->arg[0] = s->w; m->arg[1] = s->w + HP_NX; m->arg[2] = P; m->arg[3] = lam_gap;
#if HP_H0
    m->arg[4] = p + HP_NX + HP_N * HP_NP;
#endif
    m->res[0] = &s->cost; m->res[1] = s->grad; m->res[2] = s->F; m->res[3] = s->AB; m->res[4] = s->hess;
    if (HP_LIN0(m->arg, m->res, m->iw, m->w, 0)) return 1;
  } else if (k < HP_N) {
    m->arg[0] = s->w; m->arg[1] = s->w + HP_NX; m->arg[2] = P; m->arg[3] = lam_gap; m->arg[4] = lam_rows;
    m->res[0] = &s->cost; m->res[1] = s->grad; m->res[2] = s->F; m->res[3] = s->AB;
    m->res[4] = s->rows; m->res[5] = s->J; m->res[6] = s->hess;
    if (HP_LINK(m->arg, m->res, m->iw, m->w, 0)) return 1;
  } else {
    m->arg[0] = s->w; m->arg[1] = P; m->arg[2] = lam_rows;
    m->res[0] = &s->cost; m->res[1] = s->grad; m->res[2] = s->rows; m->res[3] = s->J; m->res[4] = s->hess;
    if (HP_LINN(m->arg, m->res, m->iw, m->w, 0)) return 1;
  }
  if (!isfinite(s->cost) || !hp_finite(s->grad, nv) || !hp_finite(s->hess, nv * nv)) return 1;
  if (k < HP_N && (!hp_finite(s->F, HP_NX) || !hp_finite(s->AB, HP_NX * HP_NV))) return 1;
  if (hp_has_rows(k) && (!hp_finite(s->rows, HP_NR) || !hp_finite(s->J, HP_NR * HP_NX))) return 1;
  return 0;
}
