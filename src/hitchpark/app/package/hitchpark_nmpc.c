/* hitchpark_nmpc.c: one tick of hitchpark's full-model NMPC around its solver, on caller memory.
 *
 * The same steps as hitchpark's in-process controller (hitchpark.control.nmpc.FullNMPC and
 * hitchpark.control.receding.RecedingHorizon), in the same order and arithmetic:
 *   1. the measured pose into the parking frame of the goal, the actual steer and speed beside it;
 *   2. the state predicted over the commands still in flight (the known delay), one controller sample
 *      of the OCP's model each, their rates clipped to the limits;
 *   3. a state that is not finite, or a hitch past max_hitch, is refused: a stop, the wheels held;
 *   4. the prediction grid: the first prediction step shortens by dt each sample until less than a
 *      sample of it is left, then the grid moves on a whole step (hitchpark's _next_first_step);
 *   5. the warm start: the last plan moved on as the grid moved, or, with none, reverse from standing
 *      with the acceleration at its limit, rolled out over the model; the multipliers moved alike;
 *   6. the solve (riccati_ipm.inc, the very solver of the in-process route), and when a warm-started
 *      solve fails, one more from the cold start;
 *   7. the first sample of the plan as the command: steer and speed moved at the planned rates for dt,
 *      within their limits; a stop when both the plan and the car are at rest.
 * The in-process controller has one more step that this package has not: when the structured solver
 * fails, it asks IPOPT before the cold retry. Where that happens the two differ (hitchpark sil counts it).
 *
 * No allocation, no I/O, no global mutable state: everything lives in the caller's workspace.
 */

#if !defined(HITCHPARK_NMPC_CLOCK_NS) && !defined(HITCHPARK_NMPC_NO_CLOCK) && (defined(__unix__) || defined(__APPLE__))
#define _POSIX_C_SOURCE 199309L
#include <time.h>
#define HPC_POSIX_CLOCK 1
#endif
#include <stddef.h>
#include <stdint.h>
#include "hitchpark_nmpc.h"
#include "hitchpark_nmpc_config.h"
#include "riccati_ipm.inc"

int HPC_MODEL_STEP(const real** arg, real** res, casadi_int* iw, real* w, int mem);
int HPC_PREDICT_STEP(const real** arg, real** res, casadi_int* iw, real* w, int mem);

#define HPC_MAGIC 0x4e4d5043UL
#define HPC_NPAR (HP_NX + HP_N * HP_NP + HP_H0)
#define HPC_PI 3.141592653589793
#define HPC_STEER 4
#define HPC_SPEED 5

#if HP_NP != 0 || HP_NR != 0 || HP_H0 != 1 || HP_NX != 6 || HP_NU != 2
#error "this controller is the full-model OCP of open space (no step parameters, no rows, the first step a parameter)"
#endif

struct hitchpark_nmpc {
  unsigned long magic;
  struct hp_work solver;
  real w0[HP_NW], lbx[HP_NW], ubx[HP_NW], lbg[HP_NG], ubg[HP_NG], par[HPC_NPAR];
  real lam_x0[HP_NW], lam_g0[HP_NG];
  real x_out[HP_NW], f_out, g_out[HP_NG], lam_x[HP_NW], lam_g[HP_NG];
  real last_w[HP_NW];                     /* the last plan, states and inputs (has_last) */
  real last_lam_x[HP_NW], last_lam_g[HP_NG]; /* its multipliers (has_duals) */
  real x0[HP_NX];                         /* the state the last step solved from */
  real first_step, first_now, last_steer, cost;
  int has_last, has_duals, solver_code, iterations, converged; /* converged: the last solve's */
};

/* C99's static assertion: the workspace the header promises holds the controller. */
typedef char hpc_workspace_fits[sizeof(struct hitchpark_nmpc) <= HITCHPARK_NMPC_WORKSPACE_BYTES ? 1 : -1];

static const char* const hpc_messages[] = {
  "ok",
  "a null pointer was passed",
  "the workspace is not initialized (or was overwritten)",
  "non-finite state",
  "hitch angle beyond max_hitch",
  "the solver did not converge",
  "non-finite solver input (start or parameters)",
  "non-finite solution",
  "non-finite vehicle command",
  "an argument is out of range",
  "too little memory, or not aligned for a double",
};

static long long hpc_now_ns(void) {
#if defined(HITCHPARK_NMPC_CLOCK_NS)
  return (long long) (HITCHPARK_NMPC_CLOCK_NS());
#elif defined(HPC_POSIX_CLOCK)
  struct timespec t;
  if (clock_gettime(CLOCK_MONOTONIC, &t) != 0) return 0;
  return (long long) t.tv_sec * 1000000000LL + (long long) t.tv_nsec;
#else
  return 0;
#endif
}

/* Python's max(a, b) and min(a, b) on floats: the first unless the second is greater (smaller). */
static real hpc_clamp(real v, real lo, real hi) {
  if (lo > v) v = lo;
  if (hi < v) v = hi;
  return v;
}

/* NumPy's clip of one number. */
static real hpc_clip(real v, real lo, real hi) {
  if (!isnan(v)) v = v > lo ? v : lo;
  if (!isnan(v)) v = v < hi ? v : hi;
  return v;
}

/* Python's float modulo (the sign of the divisor). */
static real hpc_mod(real a, real b) {
  real r = fmod(a, b);
  if (r != 0.0) {
    if ((b < 0.0) != (r < 0.0)) r += b;
  } else {
    r = copysign(0.0, b);
  }
  return r;
}

/* An angle wrapped to [-pi, pi) (hitchpark.model.state.wrap_angle). */
static real hpc_wrap(real a) {
  real w = hpc_mod(a + HPC_PI, 2.0 * HPC_PI) - HPC_PI;
  return w >= HPC_PI ? w - 2.0 * HPC_PI : w;
}

static int hpc_finite(const real* v, int n) {
  int i;
  for (i = 0; i < n; ++i)
    if (!isfinite(v[i])) return 0;
  return 1;
}

static void hpc_call(struct hitchpark_nmpc* c, int (*f)(const real**, real**, casadi_int*, real*, int),
                     const real* x, const real* u, real* out) {
  struct hp_work* m = &c->solver;
  m->arg[0] = x;
  m->arg[1] = u;
  m->res[0] = out;
  f(m->arg, m->res, m->iw, m->w, 0);
}

/* The state the next command will act on, in the parking frame (FullNMPC._state). */
static void hpc_state(struct hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas, const hitchpark_nmpc_pose* goal,
                      const hitchpark_nmpc_command* in_flight, int n_in_flight, real* x) {
  real cg = cos(goal->yaw), sg = sin(goal->yaw);
  real ex = meas->x - goal->x, ey = meas->y - goal->y;
  int i, j;
  x[0] = cg * ex + sg * ey;
  x[1] = -sg * ex + cg * ey;
  x[2] = hpc_wrap(meas->yaw - goal->yaw);
  x[3] = meas->hitch;
  x[4] = meas->front_steer;
  x[5] = meas->rear_speed;
  for (i = 0; i < n_in_flight; ++i) {
    real u[2], next[HP_NX];
    u[0] = hpc_clip((in_flight[i].front_steer - x[HPC_STEER]) / HPC_DT, -HPC_MAX_STEER_RATE, HPC_MAX_STEER_RATE);
    u[1] = hpc_clip((in_flight[i].rear_speed - x[HPC_SPEED]) / HPC_DT, -HPC_MAX_ACCEL, HPC_MAX_ACCEL);
    hpc_call(c, HPC_MODEL_STEP, x, u, next);
    for (j = 0; j < HP_NX; ++j) x[j] = next[j];
  }
}

/* The next problem's first prediction step and how far the last plan moves on (RecedingHorizon._next_first_step). */
static real hpc_next_first_step(const struct hitchpark_nmpc* c, real* part) {
  real left;
  *part = 1.0;
  if (!c->has_last) return HPC_PREDICTION_DT;
  left = c->first_step - HPC_DT;
  if (left >= HPC_DT - 1e-9) {
    *part = 0.0;
    return left;
  }
  return left + HPC_PREDICTION_DT;
}

/* Stage k's entries of w moved on by part of a step, the last held (shifted_rows, per block). */
static void hpc_shift(real* v, const int* at, int n_blocks, int size, int stride, real part) {
  int k, i;
  if (part <= 0.0) return;
  for (k = 0; k < n_blocks; ++k) {
    int here = at[0] + k * stride, ahead = at[0] + (k + 1 < n_blocks ? k + 1 : k) * stride;
    for (i = 0; i < size; ++i) v[here + i] = part >= 1.0 ? v[ahead + i] : (1.0 - part) * v[here + i] + part * v[ahead + i];
  }
}

/* The bounds of the problem (MultipleShooting.bounds); free: X_0's steer freed within its limits. */
static void hpc_bounds(struct hitchpark_nmpc* c, int free) {
  int k, i;
  const real lo_x[HP_NX] = {-INFINITY, -INFINITY, -INFINITY, -HPC_HITCH_BOUND, -HPC_MAX_STEER, HPC_SPEED_MIN};
  const real hi_x[HP_NX] = {INFINITY, INFINITY, INFINITY, HPC_HITCH_BOUND, HPC_MAX_STEER, HPC_SPEED_MAX};
  for (k = 0; k <= HP_N; ++k) {
    for (i = 0; i < HP_NX; ++i) {
      c->lbx[k * HP_NV + i] = k == 0 ? -INFINITY : lo_x[i];
      c->ubx[k * HP_NV + i] = k == 0 ? INFINITY : hi_x[i];
    }
    if (k < HP_N) {
      c->lbx[k * HP_NV + HP_NX] = -HPC_MAX_STEER_RATE;
      c->ubx[k * HP_NV + HP_NX] = HPC_MAX_STEER_RATE;
      c->lbx[k * HP_NV + HP_NX + 1] = -HPC_MAX_ACCEL;
      c->ubx[k * HP_NV + HP_NX + 1] = HPC_MAX_ACCEL;
    }
  }
  for (i = 0; i < HP_NG; ++i) c->lbg[i] = c->ubg[i] = 0.0;
  if (free) {
    c->lbg[HPC_STEER] = -INFINITY;
    c->ubg[HPC_STEER] = INFINITY;
    c->lbx[HPC_STEER] = -HPC_MAX_STEER;
    c->ubx[HPC_STEER] = HPC_MAX_STEER;
  }
}

/* The warm start (RecedingHorizon._initial_guess and MultipleShooting.guess). */
static void hpc_guess(struct hitchpark_nmpc* c, const real* x0) {
  int k, i;
  real* w = c->w0;
  if (c->has_last) {
    real part;
    int xs = 0, us = HP_NX;
    hpc_next_first_step(c, &part);
    for (i = 0; i < HP_NW; ++i) w[i] = c->last_w[i];
    hpc_shift(w, &us, HP_N, HP_NU, HP_NV, part);
    hpc_shift(w, &xs, HP_N + 1, HP_NX, HP_NV, part);
  } else {
    for (k = 0; k < HP_N; ++k) {
      w[k * HP_NV + HP_NX] = 0.0;
      w[k * HP_NV + HP_NX + 1] = k < HPC_COLD_RAMP ? -HPC_MAX_ACCEL : 0.0;
    }
  }
  for (k = 0; k < HP_N; ++k) { /* np.minimum(np.maximum(inputs, u_min), u_max) */
    real* u = w + k * HP_NV + HP_NX;
    u[0] = hpc_clip(u[0], -HPC_MAX_STEER_RATE, HPC_MAX_STEER_RATE);
    u[1] = hpc_clip(u[1], -HPC_MAX_ACCEL, HPC_MAX_ACCEL);
  }
  for (i = 0; i < HP_NX; ++i) w[i] = x0[i];
  if (!c->has_last) /* the states rolled out over the model, a whole prediction step each */
    for (k = 0; k < HP_N; ++k) hpc_call(c, HPC_PREDICT_STEP, w + k * HP_NV, w + k * HP_NV + HP_NX, w + (k + 1) * HP_NV);
}

/* One solve; 0: converged with a finite answer, else the error code. Keeps the multipliers of a good one. */
static int hpc_solve(struct hitchpark_nmpc* c, int warm) {
  const real* arg[8];
  real* res[5];
  int i;
  c->has_duals = 0;
  c->solver_code = 0;
  c->iterations = 0;
  c->converged = 0;
  c->cost = NAN;
  if (!hpc_finite(c->w0, HP_NW) || !hpc_finite(c->par, HPC_NPAR)) {
    for (i = 0; i < HP_NW; ++i) c->x_out[i] = NAN;
    return HITCHPARK_NMPC_E_SOLVER_INPUT;
  }
  arg[0] = c->w0; arg[1] = c->par; arg[2] = c->lbx; arg[3] = c->ubx; arg[4] = c->lbg; arg[5] = c->ubg;
  arg[6] = c->lam_x0; arg[7] = c->lam_g0;
  res[0] = c->x_out; res[1] = &c->f_out; res[2] = c->g_out; res[3] = c->lam_x; res[4] = c->lam_g;
  if (!warm) {
    for (i = 0; i < HP_NW; ++i) c->lam_x0[i] = 0.0;
    for (i = 0; i < HP_NG; ++i) c->lam_g0[i] = 0.0;
  }
  c->solver_code = hp_solve(&c->solver, arg, res, warm, HPC_DUAL_FLOOR);
  c->iterations = c->solver.iterations;
  c->cost = c->f_out;
  c->converged = c->solver_code == 0;
  if (c->solver_code != 0) return HITCHPARK_NMPC_E_SOLVER;
  if (!hpc_finite(c->x_out, HP_NW) || !isfinite(c->f_out)) return HITCHPARK_NMPC_E_SOLUTION;
  if (hpc_finite(c->lam_x, HP_NW) && hpc_finite(c->lam_g, HP_NG)) {
    for (i = 0; i < HP_NW; ++i) c->last_lam_x[i] = c->lam_x[i];
    for (i = 0; i < HP_NG; ++i) c->last_lam_g[i] = c->lam_g[i];
    c->has_duals = 1;
  }
  return 0;
}

/* The multipliers of the warm start (MultipleShooting.shift_duals); 0: none. */
static int hpc_warm_duals(struct hitchpark_nmpc* c) {
  real part;
  int i, xs = 0, us = HP_NX, gs = 0;
  if (!HPC_WARM_DUALS || !c->has_duals || !c->has_last) return 0;
  hpc_next_first_step(c, &part);
  for (i = 0; i < HP_NW; ++i) c->lam_x0[i] = c->last_lam_x[i];
  for (i = 0; i < HP_NG; ++i) c->lam_g0[i] = c->last_lam_g[i];
  hpc_shift(c->lam_x0, &xs, HP_N + 1, HP_NX, HP_NV, part);
  hpc_shift(c->lam_x0, &us, HP_N, HP_NU, HP_NV, part);
  hpc_shift(c->lam_g0, &gs, HP_N + 1, HP_NX, HP_NX, part);
  for (i = 0; i < HP_NX; ++i) c->lam_x0[i] = 0.0;
  return 1;
}

/* The solve cascade of RecedingHorizon._solve_cascade without its fallback solver: the warm start, then the cold. */
static int hpc_cascade(struct hitchpark_nmpc* c, const real* x0, int free) {
  int cold = !c->has_last, warm, code, i;
  hpc_bounds(c, free);
  hpc_guess(c, x0);
  for (i = 0; i < HP_NX; ++i) c->par[i] = x0[i];
  c->par[HP_NX] = c->first_now;
  warm = !free && !cold && hpc_warm_duals(c);
  code = hpc_solve(c, warm);
  if (code != 0 && !cold) {
    c->has_last = 0;
    hpc_guess(c, x0);
    code = hpc_solve(c, 0);
  }
  return code;
}

static int hpc_valid(const struct hitchpark_nmpc* c) { return c != 0 && c->magic == HPC_MAGIC; }

static void hpc_status(hitchpark_nmpc_status* status, const struct hitchpark_nmpc* c, int code, int stop,
                       long long t0) {
  if (!status) return;
  status->error = code;
  status->message = hpc_messages[code];
  status->ok = code == 0;
  status->stop = stop;
  status->converged = c ? c->converged : 0;
  status->solver_code = c ? c->solver_code : 0;
  status->iterations = c ? c->iterations : 0;
  status->cost = c ? c->cost : NAN;
  status->solve_time_ns = hpc_now_ns() - t0;
}

size_t hitchpark_nmpc_workspace_size(void) { return sizeof(struct hitchpark_nmpc); }

hitchpark_nmpc* hitchpark_nmpc_init(void* memory, size_t bytes) {
  struct hitchpark_nmpc* c = (struct hitchpark_nmpc*) memory;
  if (!memory || bytes < sizeof(struct hitchpark_nmpc) || (uintptr_t) memory % sizeof(double) != 0) return 0;
  memset(c, 0, sizeof(*c));
  c->magic = HPC_MAGIC;
  c->first_step = HPC_PREDICTION_DT;
  c->first_now = HPC_PREDICTION_DT;
  c->cost = NAN;
  return c;
}

int hitchpark_nmpc_reset(hitchpark_nmpc* c, hitchpark_real front_steer) {
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  c->has_last = 0;
  c->has_duals = 0;
  c->last_steer = isfinite(front_steer) ? front_steer : 0.0;
  return 0;
}

/* Checks shared by step and initial_steer; 0: go on. */
static int hpc_checked(const struct hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas,
                       const hitchpark_nmpc_pose* goal, const hitchpark_nmpc_command* in_flight, int n_in_flight) {
  if (!c) return HITCHPARK_NMPC_E_NULL;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (!meas || !goal || (n_in_flight > 0 && !in_flight)) return HITCHPARK_NMPC_E_NULL;
  if (n_in_flight < 0 || n_in_flight > HITCHPARK_NMPC_MAX_IN_FLIGHT) return HITCHPARK_NMPC_E_ARGUMENT;
  if (!isfinite(goal->x) || !isfinite(goal->y) || !isfinite(goal->yaw)) return HITCHPARK_NMPC_E_ARGUMENT;
  return 0;
}

/* A refusal before solving: non-finite state, or the hitch past its limit (RecedingHorizon._refuse). */
static int hpc_refused(const real* x) {
  if (!hpc_finite(x, HP_NX)) return HITCHPARK_NMPC_E_STATE;
  if (fabs(x[3]) > HPC_MAX_HITCH) return HITCHPARK_NMPC_E_HITCH;
  return 0;
}

int hitchpark_nmpc_step(hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas, const hitchpark_nmpc_pose* goal,
                        const hitchpark_nmpc_command* in_flight, int n_in_flight, hitchpark_nmpc_command* command_out,
                        hitchpark_nmpc_status* status_out) {
  long long t0 = hpc_now_ns();
  real* x0;
  real part, steer, speed;
  int code = hpc_checked(c, meas, goal, in_flight, n_in_flight), stop;
  if (command_out) { /* until decided: a stop, the wheels held */
    command_out->rear_speed = 0.0;
    command_out->front_steer = hpc_valid(c) ? c->last_steer : (meas && isfinite(meas->front_steer) ? meas->front_steer : 0.0);
  }
  if (code == 0 && !command_out) code = HITCHPARK_NMPC_E_NULL;
  if (code != 0) {
    hpc_status(status_out, hpc_valid(c) ? c : 0, code, 1, t0);
    return code;
  }
  c->solver_code = 0;
  c->iterations = 0;
  c->converged = 0;
  c->cost = NAN;
  x0 = c->x0;
  hpc_state(c, meas, goal, in_flight, n_in_flight, x0);
  code = hpc_refused(x0);
  if (code == 0) {
    c->first_now = hpc_next_first_step(c, &part);
    code = hpc_cascade(c, x0, 0);
  }
  if (code == 0) {
    const real* u0 = c->x_out + HP_NX;
    steer = hpc_clamp(x0[HPC_STEER] + HPC_DT * u0[0], -HPC_MAX_STEER, HPC_MAX_STEER);
    speed = hpc_clamp(x0[HPC_SPEED] + HPC_DT * u0[1], HPC_SPEED_MIN, HPC_SPEED_MAX);
    if (!isfinite(steer) || !isfinite(speed)) code = HITCHPARK_NMPC_E_COMMAND;
  }
  if (code != 0) { /* RecedingHorizon._stop */
    c->has_last = 0;
    command_out->rear_speed = 0.0;
    command_out->front_steer = c->last_steer;
    hpc_status(status_out, c, code, 1, t0);
    return code;
  }
  stop = fabs(speed) < HPC_STOP_SPEED && fabs(x0[HPC_SPEED]) < HPC_STOP_SPEED;
  memcpy(c->last_w, c->x_out, sizeof(c->last_w));
  c->has_last = 1;
  c->first_step = c->first_now;
  if (stop) speed = 0.0;
  c->last_steer = steer;
  command_out->rear_speed = speed;
  command_out->front_steer = steer;
  hpc_status(status_out, c, 0, stop, t0);
  return 0;
}

int hitchpark_nmpc_initial_steer(hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas,
                                 const hitchpark_nmpc_pose* goal, hitchpark_real* steer_out, hitchpark_nmpc_status* status_out) {
  long long t0 = hpc_now_ns();
  real part;
  int code = hpc_checked(c, meas, goal, 0, 0);
  if (code == 0 && !steer_out) code = HITCHPARK_NMPC_E_NULL;
  if (code != 0) {
    hpc_status(status_out, hpc_valid(c) ? c : 0, code, 1, t0);
    return code;
  }
  c->solver_code = 0;
  c->iterations = 0;
  c->converged = 0;
  c->cost = NAN;
  hpc_state(c, meas, goal, 0, 0, c->x0);
  code = hpc_refused(c->x0);
  if (code != 0) {
    c->has_last = 0;
  } else {
    c->first_now = hpc_next_first_step(c, &part);
    code = hpc_cascade(c, c->x0, 1);
    if (code == 0) {
      real steer = hpc_clamp(c->x0[HPC_STEER] + HPC_DT * c->x_out[HP_NX], -HPC_MAX_STEER, HPC_MAX_STEER);
      real speed = hpc_clamp(c->x0[HPC_SPEED] + HPC_DT * c->x_out[HP_NX + 1], HPC_SPEED_MIN, HPC_SPEED_MAX);
      if (!isfinite(steer) || !isfinite(speed)) code = HITCHPARK_NMPC_E_COMMAND;
      else c->first_step = c->first_now;
    }
    /* FullNMPC.initial_steer resets the controller to the measured steer whatever the answer */
    c->has_last = 0;
    c->has_duals = 0;
    c->last_steer = meas->front_steer;
    if (code == 0) *steer_out = hpc_clamp(c->x_out[HPC_STEER], -HPC_MAX_STEER, HPC_MAX_STEER);
  }
  hpc_status(status_out, c, code, 0, t0);
  return code;
}

int hitchpark_nmpc_prediction(const hitchpark_nmpc* c, hitchpark_real* states, hitchpark_real* inputs) {
  int k, i;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  for (k = 0; k <= HP_N; ++k) {
    for (i = 0; i < HP_NX; ++i)
      if (states) states[k * HP_NX + i] = c->x_out[k * HP_NV + i];
    for (i = 0; i < HP_NU && k < HP_N; ++i)
      if (inputs) inputs[k * HP_NU + i] = c->x_out[k * HP_NV + HP_NX + i];
  }
  return 0;
}

int hitchpark_nmpc_state(const hitchpark_nmpc* c, hitchpark_real* x0) {
  int i;
  if (!hpc_valid(c) || !x0) return HITCHPARK_NMPC_E_WORKSPACE;
  for (i = 0; i < HP_NX; ++i) x0[i] = c->x0[i];
  return 0;
}

const char* hitchpark_nmpc_message(int code) {
  if (code < 0 || code >= (int) (sizeof(hpc_messages) / sizeof(hpc_messages[0]))) return "unknown error code";
  return hpc_messages[code];
}
