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
 * Before this file come the definitions of HP_N, HP_NX, HP_NU, HP_NR (rows a stage), HP_NP (parameters a
 * stage), HP_H0 (1: p ends with the first step's length, which stage 0's functions take), HP_TOL, HP_MU,
 * HP_MAX_ITER, HP_BOUND_PUSH (the least slack at the start), HP_CORRECTOR (1: Mehrotra's corrector), the
 * functions' names and their work sizes (hitchpark.solvers.riccati); optionally HP_WARM_ITER (below).
 *
 * HP_WARM_ITER > 0 (opt-in; undefined or 0: off): a real-time-iteration-like cap on a warm-started solve. After
 * that many Newton steps of a solve from the caller's multipliers, the iterate is the answer, returned as a
 * success (code 0) whether or not it meets the tolerance; its cost, dynamics and rows come from the accepted
 * trial's evaluation, so the capped solve does not linearize again at its last point. A cold start keeps
 * HP_MAX_ITER.
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

/* The one-sided constraint values c of stage k at (w, rows) into out. */
static void hp_constraints(const struct hp_stage* s, const real* w, const real* rows, real* out) {
  int i;
  for (i = 0; i < HP_NR; ++i) {
    out[i] = s->on[i] ? rows[i] - s->bound[i] : 0.0;
    out[HP_NR + i] = s->on[HP_NR + i] ? s->bound[HP_NR + i] - rows[i] : 0.0;
  }
  for (i = 0; i < HP_NV; ++i) {
    out[2 * HP_NR + i] = s->on[2 * HP_NR + i] ? w[i] - s->bound[2 * HP_NR + i] : 0.0;
    out[2 * HP_NR + HP_NV + i] = s->on[2 * HP_NR + HP_NV + i] ? s->bound[2 * HP_NR + HP_NV + i] - w[i] : 0.0;
  }
}

/* Jc dw + r for stage k: the constraints' linearized change plus a residual (c - s, or its correction). */
static void hp_slack_step(const struct hp_stage* s, const real* dw, const real* r, real* out) {
  int i, j;
  for (i = 0; i < HP_NR; ++i) {
    real jd = 0.0;
    if (!s->on[i] && !s->on[HP_NR + i]) {
      out[i] = 0.0;
      out[HP_NR + i] = 0.0;
      continue;
    }
    for (j = 0; j < HP_NX; ++j) jd += s->J[i + HP_NR * j] * dw[j];
    out[i] = s->on[i] ? jd + r[i] : 0.0;
    out[HP_NR + i] = s->on[HP_NR + i] ? -jd + r[HP_NR + i] : 0.0;
  }
  for (i = 0; i < HP_NV; ++i) {
    int lo = 2 * HP_NR + i, hi = 2 * HP_NR + HP_NV + i;
    out[lo] = s->on[lo] ? dw[i] + r[lo] : 0.0;
    out[hi] = s->on[hi] ? -dw[i] + r[hi] : 0.0;
  }
}

/* q = grad - Jc' t, t_j = tgt_j / s_j - Sigma_j r_j (r: the slacks' residual or its correction). */
static void hp_barrier_gradient(const struct hp_stage* s, int nv, const real* r, real* q) {
  int i, j;
  for (j = 0; j < nv; ++j) q[j] = s->grad[j];
  for (i = 0; i < HP_NR; ++i) {
    real t = 0.0;
    if (s->on[i]) t += s->ts[i] - s->sig[i] * r[i];
    if (s->on[HP_NR + i]) t -= s->ts[HP_NR + i] - s->sig[HP_NR + i] * r[HP_NR + i];
    if (t != 0.0) for (j = 0; j < HP_NX; ++j) q[j] -= s->J[i + HP_NR * j] * t;
  }
  for (i = 0; i < nv; ++i) {
    int lo = 2 * HP_NR + i, hi = 2 * HP_NR + HP_NV + i;
    if (s->on[lo]) q[i] -= s->ts[lo] - s->sig[lo] * r[lo];
    if (s->on[hi]) q[i] += s->ts[hi] - s->sig[hi] * r[hi];
  }
}

/* Ht = hess + Jc' Sigma Jc + delta I. upper (a stage before the last): hp_backward reads the upper triangle of its
 * Ht alone (i <= j), so the rows' terms go there alone; the last stage's Ht is its P, whole. */
static void hp_barrier_hessian(struct hp_stage* s, int nv, int upper, real delta) {
  int i, a, b;
  memcpy(s->Ht, s->hess, sizeof(real) * nv * nv);
  for (i = 0; i < HP_NR; ++i) {
    real d = (s->on[i] ? s->sig[i] : 0.0) + (s->on[HP_NR + i] ? s->sig[HP_NR + i] : 0.0);
    if (d == 0.0) continue;
    for (b = 0; b < HP_NX; ++b) {
      real jb = d * s->J[i + HP_NR * b];
      int last = upper ? b : HP_NX - 1;
      for (a = 0; a <= last; ++a) s->Ht[a + nv * b] += s->J[i + HP_NR * a] * jb;
    }
  }
  for (i = 0; i < nv; ++i) {
    int lo = 2 * HP_NR + i, hi = 2 * HP_NR + HP_NV + i;
    real d = delta;
    if (s->on[lo]) d += s->sig[lo];
    if (s->on[hi]) d += s->sig[hi];
    s->Ht[i + nv * i] += d;
  }
}

/* In-place Cholesky of the n x n column-major a (lower). 0: positive definite. */
static int hp_cholesky(real* a, int n) {
  int i, j, k;
  for (j = 0; j < n; ++j) {
    real d = a[j + n * j];
    for (k = 0; k < j; ++k) d -= a[j + n * k] * a[j + n * k];
    if (!(d > 1e-14)) return 1;
    d = sqrt(d);
    a[j + n * j] = d;
    for (i = j + 1; i < n; ++i) {
      real v = a[i + n * j];
      for (k = 0; k < j; ++k) v -= a[i + n * k] * a[j + n * k];
      a[i + n * j] = v / d;
    }
  }
  return 0;
}

/* x := (L L')^{-1} x for the factor L of hp_cholesky. */
static void hp_chol_solve(const real* L, int n, real* x) {
  int i, k;
  for (i = 0; i < n; ++i) {
    for (k = 0; k < i; ++k) x[i] -= L[i + n * k] * x[k];
    x[i] /= L[i + n * i];
  }
  for (i = n - 1; i >= 0; --i) {
    for (k = i + 1; k < n; ++k) x[i] -= L[k + n * i] * x[k];
    x[i] /= L[i + n * i];
  }
}

/* v = P b + p for the cost to go P, p of the stage after. */
static void hp_cost_to_go(const struct hp_stage* next, const real* b, real* v) {
  int i, j; /* column by column: each v[i] sums in the same order, the inner loop over i vectorizes */
  for (i = 0; i < HP_NX; ++i) v[i] = next->p[i];
  for (j = 0; j < HP_NX; ++j)
    for (i = 0; i < HP_NX; ++i) v[i] += next->P[i + HP_NX * j] * b[j];
}

/* The backward recursion: factors and the cost to go. 0: every R_bar positive definite. */
static int hp_backward(struct hp_work* m) {
  int k, i, j, l;
  struct hp_stage* last = &m->st[HP_N];
  memcpy(last->P, last->Ht, sizeof(real) * HP_NX * HP_NX);
  memcpy(last->p, last->qt, sizeof(real) * HP_NX);
  for (k = HP_N - 1; k >= 0; --k) {
    struct hp_stage* s = &m->st[k];
    const struct hp_stage* n = &m->st[k + 1];
    real PAB[HP_NX * HP_NV], Hb[HP_NV * HP_NV], v[HP_NX], qb[HP_NV];
    /* PAB = P_{k+1} AB; Hb = Ht + AB' PAB; qb = qt + AB' (P b + p). */
    for (j = 0; j < HP_NV; ++j) { /* each entry summed over l in order, as a dot product; the loop over i inside */
      for (i = 0; i < HP_NX; ++i) PAB[i + HP_NX * j] = 0.0;
      for (l = 0; l < HP_NX; ++l)
        for (i = 0; i < HP_NX; ++i) PAB[i + HP_NX * j] += n->P[i + HP_NX * l] * s->AB[l + HP_NX * j];
    }
    for (j = 0; j < HP_NV; ++j)
      for (i = 0; i <= j; ++i) {
        real a = s->Ht[i + HP_NV * j];
        for (l = 0; l < HP_NX; ++l) a += s->AB[l + HP_NX * i] * PAB[l + HP_NX * j];
        Hb[i + HP_NV * j] = Hb[j + HP_NV * i] = a;
      }
    hp_cost_to_go(n, s->b, v);
    for (i = 0; i < HP_NV; ++i) {
      real a = s->qt[i];
      for (l = 0; l < HP_NX; ++l) a += s->AB[l + HP_NX * i] * v[l];
      qb[i] = a;
    }
    /* R_bar = Hb[u, u]: its factor; K = -R_bar^{-1} S_bar, kk = -R_bar^{-1} r_bar. */
    for (j = 0; j < HP_NU; ++j)
      for (i = 0; i < HP_NU; ++i) s->L[i + HP_NU * j] = Hb[HP_NX + i + HP_NV * (HP_NX + j)];
    if (hp_cholesky(s->L, HP_NU)) return 1;
    for (j = 0; j < HP_NX; ++j) {
      real col[HP_NU];
      for (i = 0; i < HP_NU; ++i) col[i] = -Hb[HP_NX + i + HP_NV * j];
      hp_chol_solve(s->L, HP_NU, col);
      for (i = 0; i < HP_NU; ++i) s->K[i + HP_NU * j] = col[i];
    }
    for (i = 0; i < HP_NU; ++i) s->kk[i] = -(s->rbar[i] = qb[HP_NX + i]);
    hp_chol_solve(s->L, HP_NU, s->kk);
    /* P = Q_bar + S_bar' K, p = q_bar + K' r_bar (S_bar' kk = K' r_bar). */
    for (j = 0; j < HP_NX; ++j)
      for (i = 0; i <= j; ++i) {
        real a = Hb[i + HP_NV * j];
        for (l = 0; l < HP_NU; ++l) a += Hb[HP_NX + l + HP_NV * i] * s->K[l + HP_NU * j];
        s->P[i + HP_NX * j] = s->P[j + HP_NX * i] = a;
      }
    for (i = 0; i < HP_NX; ++i) {
      real a = qb[i];
      for (l = 0; l < HP_NU; ++l) a += s->K[l + HP_NU * i] * s->rbar[l];
      s->p[i] = a;
    }
  }
  if (m->n_free) { /* X_0's free components minimize the cost to go: P_0 on them positive definite */
    int a = 0, b;
    for (j = 0; j < HP_NX; ++j) {
      if (!m->free0[j]) continue;
      b = 0;
      for (i = 0; i < HP_NX; ++i)
        if (m->free0[i]) m->L0[b++ + m->n_free * a] = m->st[0].P[i + HP_NX * j];
      ++a;
    }
    if (hp_cholesky(m->L0, m->n_free)) return 1;
  }
  return 0;
}

/* The backward recursion of the vectors alone (the factors kept): for a corrected right-hand side. */
static void hp_backward_vectors(struct hp_work* m) {
  int k, i, l;
  struct hp_stage* last = &m->st[HP_N];
  memcpy(last->p, last->qt, sizeof(real) * HP_NX);
  for (k = HP_N - 1; k >= 0; --k) {
    struct hp_stage* s = &m->st[k];
    real v[HP_NX], qb[HP_NV];
    hp_cost_to_go(&m->st[k + 1], s->b, v);
    for (i = 0; i < HP_NV; ++i) {
      real a = s->qt[i];
      for (l = 0; l < HP_NX; ++l) a += s->AB[l + HP_NX * i] * v[l];
      qb[i] = a;
    }
    for (i = 0; i < HP_NU; ++i) s->kk[i] = -(s->rbar[i] = qb[HP_NX + i]);
    hp_chol_solve(s->L, HP_NU, s->kk);
    for (i = 0; i < HP_NX; ++i) {
      real a = qb[i];
      for (l = 0; l < HP_NU; ++l) a += s->K[l + HP_NU * i] * s->rbar[l];
      s->p[i] = a;
    }
  }
}

/* The forward recursion: dw from dX_0 = e0 (its free components those that minimize the cost to go
 * P_0, p_0), and the new multipliers -(P dX + p). */
static void hp_forward(struct hp_work* m, const real* e0) {
  int k, i, j;
  real dx[HP_NX];
  memcpy(dx, e0, sizeof(dx));
  if (m->n_free) {
    const struct hp_stage* s = &m->st[0];
    real v[HP_NX];
    int a = 0;
    for (i = 0; i < HP_NX; ++i) {
      real r;
      if (!m->free0[i]) continue;
      r = -s->p[i];
      for (j = 0; j < HP_NX; ++j) if (!m->free0[j]) r -= s->P[i + HP_NX * j] * e0[j];
      v[a++] = r;
    }
    hp_chol_solve(m->L0, m->n_free, v);
    a = 0;
    for (i = 0; i < HP_NX; ++i) if (m->free0[i]) dx[i] = v[a++];
  }
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    memcpy(s->dw, dx, sizeof(dx));
    { /* the sums column by column (each entry's in the same order) */
      real a[HP_NX];
      for (i = 0; i < HP_NX; ++i) a[i] = s->p[i];
      for (j = 0; j < HP_NX; ++j)
        for (i = 0; i < HP_NX; ++i) a[i] += s->P[i + HP_NX * j] * dx[j];
      for (i = 0; i < HP_NX; ++i) s->lam_new[i] = k == 0 && m->free0[i] ? 0.0 : -a[i]; /* no row: no multiplier */
    }
    if (k == HP_N) break;
    for (i = 0; i < HP_NU; ++i) s->dw[HP_NX + i] = s->kk[i];
    for (j = 0; j < HP_NX; ++j)
      for (i = 0; i < HP_NU; ++i) s->dw[HP_NX + i] += s->K[i + HP_NU * j] * dx[j];
    for (i = 0; i < HP_NX; ++i) dx[i] = s->b[i];
    for (j = 0; j < HP_NV; ++j)
      for (i = 0; i < HP_NX; ++i) dx[i] += s->AB[i + HP_NX * j] * s->dw[j];
  }
}

/* The largest step in (0, 1] that keeps v + a dv >= (1 - tau) v. */
static real hp_to_boundary(const signed char* on, const real* v, const real* dv, int n, real a, real mu) {
  int i;
  const real tau = hp_fmax(0.99, 1.0 - mu); /* IPOPT's tau_min 0.99 */
  for (i = 0; i < n; ++i)
    if (on[i] && dv[i] < 0.0) {
      real r = -tau * v[i] / dv[i];
      if (r < a) a = r;
    }
  return a;
}

/* sum over stages of the l1 residuals at w (trial = 0) or wt: X_0 - x0, the gaps, c - s. */
static real hp_infeasibility(const struct hp_work* m, const real* x0, int trial) {
  real sum = 0.0;
  int k, i;
  for (k = 0; k <= HP_N; ++k) {
    const struct hp_stage* s = &m->st[k];
    const real* w = trial ? s->wt : s->w;
    const real* c = trial ? s->ct : s->c;
    const real* sl = trial ? s->st : s->s;
    if (k == 0) for (i = 0; i < HP_NX; ++i) sum += m->free0[i] ? 0.0 : fabs(w[i] - x0[i]);
    else {
      const struct hp_stage* b = &m->st[k - 1];
      const real* F = trial ? b->Ft : b->F;
      for (i = 0; i < HP_NX; ++i) sum += fabs(w[i] - F[i]);
    }
    for (i = 0; i < HP_NC; ++i) if (s->on[i]) sum += fabs(c[i] - sl[i]);
  }
  return sum;
}

/* f - mu sum(log s) at w or wt. */
static real hp_barrier(struct hp_work* m, int trial) {
  real sum = 0.0;
  int k, i, fresh = trial || !m->lg_ok; /* log s: the accepted trial's log st, kept */
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    const real* sl = trial ? s->st : s->s;
    real* lg = trial ? s->lgt : s->lg;
    sum += trial ? s->cost_t : s->cost;
    for (i = 0; i < HP_NC; ++i)
      if (s->on[i]) {
        if (fresh) lg[i] = log(sl[i]);
        sum -= m->mu * lg[i];
      }
  }
  if (!trial) m->lg_ok = 1;
  return sum;
}

/* Evaluate every stage at its trial point (wt, st): theta and phi there. 0: every function finite. */
static int hp_trial(struct hp_work* m, const real* x0, const real* p, real* theta, real* phi) {
  int k;
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    if (hp_eval(m, k, p, 1)) return 1;
    hp_constraints(s, s->wt, s->rows_t, s->ct);
  }
  *theta = hp_infeasibility(m, x0, 1);
  *phi = hp_barrier(m, 1);
  return !isfinite(*phi);
}

/* IPOPT's acceptance of a trial point (theta_t, phi_t) at step a from (theta, phi), slope D of phi along the
 * step: 1 if accepted, and *armijo whether by the switching condition and Armijo's (an f-type step, which
 * leaves the filter as it is). */
static int hp_acceptable(const struct hp_work* m, real a, real theta, real phi, real D, real theta_t, real phi_t,
                         int* armijo) {
  int i;
  *armijo = 0;
  if (!(theta_t <= m->theta_max) || !isfinite(phi_t)) return 0;
  for (i = 0; i < m->filter_size; ++i)
    if (theta_t >= m->filter_theta[i] && phi_t >= m->filter_phi[i]) return 0;
  if (theta <= m->theta_min && D < 0.0 && a * pow(-D, 2.3) > pow(theta, 1.1)) {
    /* eta_phi 1e-8, with room for the rounding of phi (IPOPT's 10 machine epsilons) */
    *armijo = phi_t - phi <= 1e-8 * a * D + 1e-15 * 10.0 * fabs(phi);
    return *armijo;
  }
  return theta_t <= (1.0 - 1e-5) * theta || phi_t <= phi - 1e-8 * theta;
}

/* Set every stage's trial point w + a dw, s + a ds. */
static void hp_set_trial(struct hp_work* m, real a) {
  int k, i;
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    for (i = 0; i < hp_nv(k); ++i) s->wt[i] = s->w[i] + a * s->dw[i];
    for (i = 0; i < HP_NC; ++i) s->st[i] = s->on[i] ? s->s[i] + a * s->ds[i] : 1.0;
  }
}

/* The step of the multipliers z from the step of the slacks: dz = tgt / s - z - Sigma ds. */
static void hp_dual_step(struct hp_stage* s) {
  int i;
  for (i = 0; i < HP_NC; ++i) s->dz[i] = s->on[i] ? s->ts[i] - s->z[i] - s->sig[i] * s->ds[i] : 0.0;
}

/* The step (dw, ds, dz) once the backward recursion is done: the forward one, the slacks' and multipliers'
 * steps; the largest steps of s and z within the fraction to the boundary into *a_s, *a_z. */
static void hp_step_after(struct hp_work* m, real* a_s, real* a_z) {
  int k, i;
  *a_s = *a_z = 1.0;
  hp_forward(m, m->e0);
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    real r[HP_NC];
    for (i = 0; i < HP_NC; ++i) r[i] = s->c[i] - s->s[i];
    hp_slack_step(s, s->dw, r, s->ds);
    hp_dual_step(s);
    *a_s = hp_to_boundary(s->on, s->s, s->ds, HP_NC, *a_s, m->mu);
    *a_z = hp_to_boundary(s->on, s->z, s->dz, HP_NC, *a_z, m->mu);
  }
}

/* The same for new right-hand sides qt, b, e0, the factors kept: the backward recursion of the vectors first. */
static void hp_step_vectors(struct hp_work* m, real* a_s, real* a_z) {
  hp_backward_vectors(m);
  hp_step_after(m, a_s, a_z);
}

/* The slope of the barrier function phi along the step (dw, ds). */
static real hp_slope(const struct hp_work* m) {
  real d = 0.0;
  int k, i;
  for (k = 0; k <= HP_N; ++k) {
    const struct hp_stage* s = &m->st[k];
    for (i = 0; i < hp_nv(k); ++i) d += s->grad[i] * s->dw[i];
    for (i = 0; i < HP_NC; ++i) if (s->on[i]) d -= m->mu * s->ds[i] / s->s[i];
  }
  return d;
}

/* Every stage's barrier gradient qt at the residuals c - s, for the targets tgt. */
static void hp_gradients(struct hp_work* m) {
  int k, i;
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    real r[HP_NC];
    for (i = 0; i < HP_NC; ++i) s->ts[i] = s->on[i] ? s->tgt[i] / s->s[i] : 0.0;
    for (i = 0; i < HP_NC; ++i) r[i] = s->c[i] - s->s[i];
    hp_barrier_gradient(s, hp_nv(k), r, s->qt);
  }
}

/* The step without the corrector: targets mu, its right-hand sides and vectors (the factors kept). */
static void hp_uncorrected(struct hp_work* m, real* a_s, real* a_z) {
  int k, i;
  for (k = 0; k <= HP_N; ++k)
    for (i = 0; i < HP_NC; ++i) m->st[k].tgt[i] = m->mu;
  hp_gradients(m);
  hp_step_vectors(m, a_s, a_z);
}

/* The optimality error (IPOPT's, scaled), with the current multipliers: of the barrier problem of mu
 * (complementarity s z - mu), or of the NLP (mu = 0). */
static real hp_error(struct hp_work* m, const real* x0, real mu) {
  real rd = 0.0, pr = 0.0, co = 0.0, sum_l = 0.0, sum_z = 0.0;
  long n_l = 0, n_z = 0;
  int k, i, j;
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    int nv = hp_nv(k);
    real r[HP_NV];
    for (j = 0; j < nv; ++j) r[j] = s->grad[j];
    for (j = 0; j < HP_NX; ++j) r[j] += s->lam[j];
    if (k < HP_N) {
      const real* ln = m->st[k + 1].lam;
      for (j = 0; j < HP_NV; ++j)
        for (i = 0; i < HP_NX; ++i) r[j] -= s->AB[i + HP_NX * j] * ln[i];
    }
    for (i = 0; i < HP_NR; ++i) {
      real y = (s->on[i] ? s->z[i] : 0.0) - (s->on[HP_NR + i] ? s->z[HP_NR + i] : 0.0);
      if (y != 0.0) for (j = 0; j < HP_NX; ++j) r[j] -= s->J[i + HP_NR * j] * y;
    }
    for (j = 0; j < nv; ++j) {
      int lo = 2 * HP_NR + j, hi = 2 * HP_NR + HP_NV + j;
      if (s->on[lo]) r[j] -= s->z[lo];
      if (s->on[hi]) r[j] += s->z[hi];
    }
    for (j = 0; j < nv; ++j) rd = hp_fmax(rd, fabs(r[j]));
    for (j = 0; j < HP_NX; ++j) {
      real gap = k == 0 ? (m->free0[j] ? 0.0 : s->w[j] - x0[j]) : s->w[j] - m->st[k - 1].F[j];
      pr = hp_fmax(pr, fabs(gap));
      sum_l += fabs(s->lam[j]);
    }
    n_l += HP_NX;
    for (i = 0; i < HP_NC; ++i)
      if (s->on[i]) {
        pr = hp_fmax(pr, fabs(s->c[i] - s->s[i]));
        co = hp_fmax(co, fabs(s->s[i] * s->z[i] - mu));
        sum_z += s->z[i];
        ++n_z;
      }
  }
  {
    const real s_max = 100.0;
    real sd = hp_fmax(s_max, (sum_l + sum_z) / (real)(n_l + n_z)) / s_max;
    real sc = n_z ? hp_fmax(s_max, sum_z / (real)n_z) / s_max : 1.0;
    return hp_fmax(hp_fmax(rd / sd, pr), co / sc);
  }
}

/* The solve. Returns 0 on convergence; 1: not converged in HP_MAX_ITER iterations; 2: the line search
 * failed; 3: a function was not finite at the start; 4: inputs the method does not take (bounds on the
 * gaps other than 0, on X_0's rows other than 0 or both infinite, or equality rows). */
static int hp_solve(struct hp_work* m, const real** arg, real** res, int warm, real floor) {
  const real *x_in = arg[0], *p = arg[1], *lbx = arg[2], *ubx = arg[3], *lbg = arg[4], *ubg = arg[5];
  const real *lam_x0 = arg[6], *lam_g0 = arg[7];
  const real* x0 = p; /* the initial state: p's first HP_NX */
  int k, i, it, code = 1;
  warm = warm && lam_x0 && lam_g0 && hp_finite(lam_x0, HP_NW) && hp_finite(lam_g0, HP_NG); /* else: cold */
  m->iterations = 0;
  m->filter_size = 0;
  m->mu = warm ? HP_MU : HP_MU_COLD;
  m->lg_ok = 0;
  m->capped = 0;
  m->n_free = 0;
  if (!lbg || !ubg) return 4;
  for (i = 0; i < HP_NX; ++i) { /* X_0's rows: X_0 = x0, or the component free (both bounds infinite) */
    m->free0[i] = isinf(lbg[i]) && lbg[i] < 0.0 && isinf(ubg[i]) && ubg[i] > 0.0;
    if (!m->free0[i] && (lbg[i] != 0.0 || ubg[i] != 0.0)) return 4;
    m->n_free += m->free0[i];
  }
  /* --- the start --- */
  for (k = 0; k <= HP_N; ++k) {
    struct hp_stage* s = &m->st[k];
    int nv = hp_nv(k), gap = k == 0 ? 0 : hp_gap_at(k - 1), ra = hp_rows_at(k);
    for (i = 0; i < HP_NX; ++i)
      if (k > 0 && (lbg[gap + i] != 0.0 || ubg[gap + i] != 0.0)) return 4;
    for (i = 0; i < nv; ++i) s->w[i] = x_in ? x_in[k * HP_NV + i] : 0.0;
    memset(s->on, 0, sizeof(s->on));
    for (i = 0; i < HP_NR; ++i) {
      real lo, hi;
      if (!hp_has_rows(k)) break;
      lo = lbg[ra + i];
      hi = ubg[ra + i];
      if (lo == hi) return 4;
      s->on[i] = isfinite(lo);
      s->bound[i] = lo;
      s->on[HP_NR + i] = isfinite(hi);
      s->bound[HP_NR + i] = hi;
    }
    for (i = 0; i < nv; ++i) {
      real lo = lbx ? lbx[k * HP_NV + i] : -INFINITY, hi = ubx ? ubx[k * HP_NV + i] : INFINITY;
      int a = 2 * HP_NR + i, b = 2 * HP_NR + HP_NV + i;
      s->on[a] = isfinite(lo);
      s->bound[a] = lo;
      s->on[b] = isfinite(hi);
      s->bound[b] = hi;
    }
    /* The constraints at the start: of w alone without rows (iteration 0's hp_linearize evaluates the stage
     * anyway and fails as this would, code 3), else of the rows too. */
    if (HP_NR > 0 && hp_eval(m, k, p, 0)) return 3;
    hp_constraints(s, s->w, s->rows, s->c);
    for (i = 0; i < HP_NC; ++i)
      s->s[i] = s->on[i] ? hp_fmax(s->c[i], warm ? HP_BOUND_PUSH : HP_PUSH_COLD * hp_fmax(1.0, fabs(s->bound[i]))) : 1.0;
    /* Multipliers: the caller's (bounds' at least floor), or none (z = 1, lam = 0). */
    for (i = 0; i < HP_NC; ++i) s->z[i] = s->on[i] ? 1.0 : 0.0;
    for (i = 0; i < HP_NX; ++i) s->lam[i] = warm && !(k == 0 && m->free0[i]) ? lam_g0[gap + i] : 0.0;
    if (warm) {
      for (i = 0; i < HP_NR; ++i) {
        if (!hp_has_rows(k)) break;
        if (s->on[i]) s->z[i] = hp_fmax(-lam_g0[ra + i], floor);
        if (s->on[HP_NR + i]) s->z[HP_NR + i] = hp_fmax(lam_g0[ra + i], floor);
      }
      for (i = 0; i < nv; ++i) {
        int a = 2 * HP_NR + i, b = 2 * HP_NR + HP_NV + i;
        if (s->on[a]) s->z[a] = hp_fmax(-lam_x0[k * HP_NV + i], floor);
        if (s->on[b]) s->z[b] = hp_fmax(lam_x0[k * HP_NV + i], floor);
      }
    }
  }
  /* --- the iterations --- */
  for (it = 0;; ++it) {
    real delta, phi0, theta0, D0, a, a_max, a_z = 1.0, phi_t, theta_t;
    int accepted = 0, armijo = 0, corrected = 0;
    for (k = 0; k <= HP_N; ++k)
      if (hp_linearize(m, k, p)) { code = it == 0 ? 3 : 2; goto done; }
    for (k = 0; k <= HP_N; ++k) hp_constraints(&m->st[k], m->st[k].w, m->st[k].rows, m->st[k].c);
    if (m->mu <= HP_MU && hp_error(m, x0, 0.0) <= HP_TOL) { code = 0; break; } /* mu down first: the same answer as warm */
    if (it >= HP_MAX_ITER) { code = 1; break; }
    /* From a cold start: IPOPT's monotone update of mu (kappa_eps 10, kappa_mu 0.2, theta_mu 1.5), the
     * filter anew with each new mu, down to HP_MU. */
    while (m->mu > HP_MU && hp_error(m, x0, m->mu) <= 10.0 * m->mu) {
      m->mu = hp_fmax(HP_MU, hp_fmin(0.2 * m->mu, pow(m->mu, 1.5)));
      m->filter_size = 0;
    }
    /* The Newton step: the barrier's blocks, the Riccati recursion, with delta I where needed. */
    for (i = 0; i < HP_NX; ++i) m->e0[i] = x0[i] - m->st[0].w[i];
    for (k = 0; k <= HP_N; ++k) {
      struct hp_stage* s = &m->st[k];
      for (i = 0; i < HP_NC; ++i) s->tgt[i] = m->mu;
      for (i = 0; i < HP_NC; ++i) s->sig[i] = s->on[i] ? s->z[i] / s->s[i] : 0.0;
      if (k < HP_N) for (i = 0; i < HP_NX; ++i) s->b[i] = s->F[i] - m->st[k + 1].w[i];
    }
    hp_gradients(m);
    delta = 0.0;
    for (;;) {
      for (k = 0; k <= HP_N; ++k) hp_barrier_hessian(&m->st[k], hp_nv(k), k < HP_N, delta);
      if (!hp_backward(m)) break;
      delta = delta == 0.0 ? (m->delta_last == 0.0 ? 1e-4 : hp_fmax(1e-20, m->delta_last / 3.0)) : 8.0 * delta;
      if (delta > 1e40) { code = 2; goto done; }
    }
    m->delta_last = delta;
    hp_step_after(m, &a_max, &a_z);
    if (HP_CORRECTOR && m->mu <= HP_MU) {
      /* Mehrotra's corrector: the step's own second-order term in the complementarity, s z -> mu - ds dz
       * (the factors kept). Tried where it leaves the step at least as long; else the step as it was. */
      real a_c, a_zc;
      for (k = 0; k <= HP_N; ++k) {
        struct hp_stage* s = &m->st[k];
        for (i = 0; i < HP_NC; ++i) s->tgt[i] = m->mu - (s->on[i] ? s->ds[i] * s->dz[i] : 0.0);
      }
      hp_gradients(m);
      hp_step_vectors(m, &a_c, &a_zc);
      corrected = hp_fmin(a_c, a_zc) >= hp_fmin(a_max, a_z);
      if (corrected) {
        a_max = a_c;
        a_z = a_zc;
      } else
        hp_uncorrected(m, &a_max, &a_z);
    }
    /* theta, phi and phi's slope along the step. */
    theta0 = hp_infeasibility(m, x0, 0);
    phi0 = hp_barrier(m, 0);
    if (it == 0) {
      m->theta_max = 1e4 * hp_fmax(1.0, theta0);
      m->theta_min = 1e-4 * hp_fmax(1.0, theta0);
    }
    D0 = hp_slope(m);
    /* The line search: the corrected full step, else the step uncorrected, with one second-order correction of
     * a rejected full step. */
    a = a_max;
    hp_set_trial(m, a);
    if (!hp_trial(m, x0, p, &theta_t, &phi_t)) accepted = hp_acceptable(m, a, theta0, phi0, D0, theta_t, phi_t, &armijo);
    if (!accepted && corrected) {
      hp_uncorrected(m, &a_max, &a_z);
      D0 = hp_slope(m);
      a = a_max;
      hp_set_trial(m, a);
      if (!hp_trial(m, x0, p, &theta_t, &phi_t))
        accepted = hp_acceptable(m, a, theta0, phi0, D0, theta_t, phi_t, &armijo);
    }
    if (!accepted && isfinite(phi_t) && theta_t >= theta0) {
      /* Correct for the residuals at the full step: the same matrix, the residuals a_max r(w) + r(wt). */
      real a_s = 1.0;
      for (i = 0; i < HP_NX; ++i) m->e0[i] = a_max * m->e0[i] + (x0[i] - m->st[0].wt[i]);
      for (k = 0; k <= HP_N; ++k) {
        struct hp_stage* s = &m->st[k];
        real r[HP_NC];
        for (i = 0; i < HP_NC; ++i) r[i] = a_max * (s->c[i] - s->s[i]) + (s->ct[i] - s->st[i]);
        hp_barrier_gradient(s, hp_nv(k), r, s->qt);
        if (k < HP_N) for (i = 0; i < HP_NX; ++i) s->b[i] = a_max * s->b[i] + (s->Ft[i] - m->st[k + 1].wt[i]);
        memcpy(s->ct, r, sizeof(r)); /* kept for the slack step below */
      }
      hp_backward_vectors(m);
      hp_forward(m, m->e0);
      for (k = 0; k <= HP_N; ++k) {
        struct hp_stage* s = &m->st[k];
        real r[HP_NC];
        memcpy(r, s->ct, sizeof(r));
        hp_slack_step(s, s->dw, r, s->ds);
        a_s = hp_to_boundary(s->on, s->s, s->ds, HP_NC, a_s, m->mu);
      }
      hp_set_trial(m, a_s);
      if (!hp_trial(m, x0, p, &theta_t, &phi_t))
        accepted = hp_acceptable(m, a_max, theta0, phi0, D0, theta_t, phi_t, &armijo);
      if (accepted) {
        a = a_s;
        a_z = 1.0;
        for (k = 0; k <= HP_N; ++k) {
          hp_dual_step(&m->st[k]);
          a_z = hp_to_boundary(m->st[k].on, m->st[k].z, m->st[k].dz, HP_NC, a_z, m->mu);
        }
      } else {
        /* Back to the step before the second-order correction: its slack step and dual step again. */
        real a_unused;
        for (i = 0; i < HP_NX; ++i) m->e0[i] = x0[i] - m->st[0].w[i];
        for (k = 0; k < HP_N; ++k)
          for (i = 0; i < HP_NX; ++i) m->st[k].b[i] = m->st[k].F[i] - m->st[k + 1].w[i];
        hp_gradients(m);
        hp_step_vectors(m, &a_unused, &a_z);
      }
    }
    {
      /* IPOPT's least step of the filter search (gamma_alpha 0.05); below it, IPOPT's restoration phase.
       * Here instead the l1 merit phi + nu theta, nu above every new multiplier, and the filter anew. */
      real a_min = 1e-5;
      int merit = 0;
      real nu = 0.0, merit0 = 0.0, slope = 0.0;
      if (D0 < 0.0) a_min = hp_fmin(a_min, hp_fmin(1e-8 * theta0 / -D0, pow(theta0, 1.1) / pow(-D0, 2.3)));
      a_min *= 0.05;
      while (!accepted) {
        a *= 0.5;
        if (a < (merit ? HP_MIN_STEP : a_min)) {
          if (merit) { code = 2; goto done; }
          merit = 1;
          for (k = 0; k <= HP_N; ++k) {
            const struct hp_stage* s = &m->st[k];
            for (i = 0; i < HP_NX; ++i) nu = hp_fmax(nu, fabs(s->lam_new[i]));
            for (i = 0; i < HP_NC; ++i) if (s->on[i]) nu = hp_fmax(nu, fabs(s->z[i] + s->dz[i]));
          }
          nu *= 1.1;
          merit0 = phi0 + nu * theta0;
          slope = D0 - nu * theta0;
          m->filter_size = 0;
          a = a_max;
        }
        hp_set_trial(m, a);
        if (hp_trial(m, x0, p, &theta_t, &phi_t)) continue;
        if (merit)
          accepted = phi_t + nu * theta_t <= merit0 + 1e-4 * a * slope + 1e-14 * fabs(merit0);
        else
          accepted = hp_acceptable(m, a, theta0, phi0, D0, theta_t, phi_t, &armijo);
      }
      armijo = armijo || merit; /* a merit step starts the filter anew */
    }
    if (!armijo) { /* an h-type step: the filter keeps out what is not better than here */
      m->filter_theta[m->filter_size] = (1.0 - 1e-5) * theta0;
      m->filter_phi[m->filter_size] = phi0 - 1e-8 * theta0;
      ++m->filter_size;
    }
    /* Take the step; the multipliers z within IPOPT's bounds of mu / s (kappa_Sigma 1e10). */
    for (k = 0; k <= HP_N; ++k) {
      struct hp_stage* s = &m->st[k];
      memcpy(s->w, s->wt, sizeof(s->w));
      for (i = 0; i < HP_NC; ++i) {
        if (!s->on[i]) continue;
        s->s[i] = s->st[i];
        s->lg[i] = s->lgt[i];
        s->z[i] += a_z * s->dz[i];
        s->z[i] = hp_fmin(hp_fmax(s->z[i], m->mu / (1e10 * s->s[i])), 1e10 * m->mu / s->s[i]);
      }
      for (i = 0; i < HP_NX; ++i) s->lam[i] += a * (s->lam_new[i] - s->lam[i]);
    }
#if HP_WARM_ITER > 0
    if (warm && it + 1 >= HP_WARM_ITER) { /* the cap: the iterate is the answer, evaluated by the accepted trial */
      for (k = 0; k <= HP_N; ++k) {
        struct hp_stage* s = &m->st[k];
        s->cost = s->cost_t;
        memcpy(s->F, s->Ft, sizeof(s->F));
        memcpy(s->rows, s->rows_t, sizeof(s->rows));
      }
      ++it;
      code = 0;
      m->capped = 1;
      goto done;
    }
#endif
  }
done:
  m->iterations = it;
  /* --- the answer, in the layout of a CasADi nlpsol --- */
  {
    real* x_out = res[0], *f_out = res[1], *g_out = res[2], *lam_x = res[3], *lam_g = res[4];
    real f = 0.0;
    for (k = 0; k <= HP_N; ++k) {
      struct hp_stage* s = &m->st[k];
      int nv = hp_nv(k), gap = k == 0 ? 0 : hp_gap_at(k - 1), ra = hp_rows_at(k);
      f += s->cost;
      for (i = 0; i < nv; ++i) {
        int lo = 2 * HP_NR + i, hi = 2 * HP_NR + HP_NV + i;
        if (x_out) x_out[k * HP_NV + i] = s->w[i];
        if (lam_x) lam_x[k * HP_NV + i] = (s->on[lo] ? -s->z[lo] : 0.0) + (s->on[hi] ? s->z[hi] : 0.0);
      }
      for (i = 0; i < HP_NX; ++i) {
        if (g_out) g_out[gap + i] = k == 0 ? s->w[i] - x0[i] : s->w[i] - m->st[k - 1].F[i];
        if (lam_g) lam_g[gap + i] = s->lam[i];
      }
      if (hp_has_rows(k)) {
        real y[HP_NRA];
        hp_row_duals(s, y);
        for (i = 0; i < HP_NR; ++i) {
          if (g_out) g_out[ra + i] = s->rows[i];
          if (lam_g) lam_g[ra + i] = y[i];
        }
      }
    }
    if (f_out) f_out[0] = f;
  }
  return code;
}
