/* hitchpark_nmpc_internal.h: what the controller's C files share (not part of the API).
 *
 * The controller (hitchpark_nmpc.c) solves one of several OCPs each tick: parking at the goal, or tracking a
 * path to it. Each OCP is its own file (hitchpark_nmpc_ocp_NAME.c: its sizes, the solver riccati_ipm.inc and the
 * OCP's part of the tick hitchpark_nmpc_ocp.inc, compiled for those sizes), reached through the entry points
 * declared here. What every OCP reads and writes lives in struct hpc_shared.
 */
#ifndef HITCHPARK_NMPC_INTERNAL_H
#define HITCHPARK_NMPC_INTERNAL_H

#include <math.h>
#include <string.h>
#include "hitchpark_nmpc.h"
#include "hitchpark_nmpc_config.h"

typedef hitchpark_real hpc_real;
typedef int (*hpc_function)(const hpc_real** arg, hpc_real** res, casadi_int* iw, hpc_real* w, int mem);

#define HPC_NX 6
#define HPC_NU 2
#define HPC_NV (HPC_NX + HPC_NU)
#define HPC_NW ((HPC_N + 1) * HPC_NV - HPC_NU) /* a plan: X_0, U_0, ..., X_N */
#define HPC_STEER 4
#define HPC_SPEED 5

/* What every OCP's tick shares: the last plan (the warm start of the next), the prediction grid, the state
 * solved from and, tracking, the reference of each prediction step; the work arrays of the model's functions. */
struct hpc_shared {
  hpc_real last_w[HPC_NW]; /* the last plan (has_last) */
  hpc_real x0[HPC_NX];     /* the state the last tick solved from, parking frame */
  hpc_real refs[HPC_N * HPC_NX]; /* tracking: the reference states of prediction steps 1..N */
  hpc_real lines[HPC_N * HPC_NL]; /* among obstacles: the lines of prediction steps 1..N (hpc_draw_lines) */
  hpc_real first_step;     /* the last plan's first prediction step [s] */
  hpc_real first_now;      /* this tick's */
  int has_last;
  int first_param;         /* 1: the OCP solved now takes the first step's length (open space), its grid fixed */
  const hpc_real* arg[HPC_FN_SZ_ARG];
  hpc_real* res[HPC_FN_SZ_RES];
  casadi_int iw[HPC_FN_SZ_IW];
  hpc_real w[HPC_FN_SZ_W];
};

/* The model's functions: one controller sample, one prediction step (hitchpark_nmpc_model.c). */
int HPC_MODEL_STEP(const hpc_real** arg, hpc_real** res, casadi_int* iw, hpc_real* w, int mem);
int HPC_PREDICT_STEP(const hpc_real** arg, hpc_real** res, casadi_int* iw, hpc_real* w, int mem);

/* f(x, u) into out, in the shared work arrays. */
void hpc_call(struct hpc_shared* sh, hpc_function f, const hpc_real* x, const hpc_real* u, hpc_real* out);
/* 1: every one of v[0..n) finite. */
int hpc_finite(const hpc_real* v, int n);
/* NumPy's clip of one number. */
hpc_real hpc_clip(hpc_real v, hpc_real lo, hpc_real hi);
/* The next problem's first prediction step, and in part how far the last plan moves on to it. */
hpc_real hpc_next_first_step(const struct hpc_shared* sh, hpc_real* part);

/* Among obstacles (hitchpark_nmpc.c): the lines of each prediction step drawn around the plan w (X_0 taken as x0)
 * into sh->lines, keep_warm: w is the last plan moved on (ClearanceConstraints.parameters); and a cold start's
 * plan to draw them around, from the guess w, into w (FullNMPC._cold_start). */
void hpc_draw_lines(struct hpc_shared* sh, const hpc_real* w, const hpc_real* x0, int keep_warm);
void hpc_cold_start(struct hpc_shared* sh, hpc_real* w, const hpc_real* x0, int free);

/* What an OCP's last solve said. */
struct hpc_report {
  int solver_code, iterations, converged;
  hpc_real cost;
};

/* An OCP's entry points (hitchpark_nmpc_ocp.inc):
 *   cascade: the solve cascade from x0 (free: X_0's steer freed within its limits); 0 or an error code;
 *   solve_from: one cold solve from the start w (a cold start's); 0 or an error code;
 *   plan: the last solve's decision vector (X_0, U_0, ..., X_N);
 *   report: the last solve's codes. */
struct hpc_ocp {
  int (*cascade)(void* block, struct hpc_shared* sh, const hpc_real* x0, int free);
  int (*solve_from)(void* block, struct hpc_shared* sh, const hpc_real* x0, const hpc_real* w, int free);
  const hpc_real* (*plan)(const void* block);
  void (*report)(const void* block, struct hpc_report* out);
};

#define HPC_DECLARE_OCP(name)                                                                   \
  int hpc_##name##_cascade(void* block, struct hpc_shared* sh, const hpc_real* x0, int free); \
  int hpc_##name##_solve_from(void* block, struct hpc_shared* sh, const hpc_real* x0, const hpc_real* w, int free); \
  const hpc_real* hpc_##name##_plan(const void* block);                                        \
  void hpc_##name##_report(const void* block, struct hpc_report* out);
HPC_OCPS(HPC_DECLARE_OCP)
#undef HPC_DECLARE_OCP

#endif
