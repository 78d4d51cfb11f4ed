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
 *   5. tracking a path (hitchpark_nmpc_follow), the reference of each prediction step: the path's point
 *      nearest the trailer axle moves on (never back), and from it the reference moves along the path at
 *      the cruise speed, braking to stop at the goal (hitchpark.ocp.reference.PathReference.window); the
 *      measured yaw onto the path's branch;
 *   6. the OCP's solve cascade (hitchpark_nmpc_ocp.inc, one file per OCP: parking at the goal, tracking the
 *      path): the warm start, the solve by riccati_ipm.inc (the very solver of the in-process route), and
 *      when a warm-started solve fails, one more from the cold start;
 *   7. the first sample of the plan as the command: steer and speed moved at the planned rates for dt,
 *      within their limits; a stop when both the plan and the car are at rest.
 * The in-process controller has one more step that this package has not: when the structured solver
 * fails, it asks IPOPT before the cold retry (hitchpark sil runs it without, to compare).
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
#include "hitchpark_nmpc_internal.h"
#if HPC_OBSTACLES
#include "geometry/clearance_lines.c" /* hitchpark's own file, as the in-process controller compiles it */
#endif

#define HPC_MAGIC 0x4e4d5043UL
#define HPC_PI 3.141592653589793

/* An OCP's block: its solver's work and arrays (hitchpark_nmpc_ocp.inc), HPC_OCP_BYTES_name set aside. */
#define HPC_BLOCK(name)     \
  union {                   \
    double align_double;    \
    long long align_ll;     \
    void* align_pointer;    \
    unsigned char bytes[HPC_OCP_BYTES_##name]; \
  } name;

struct hitchpark_nmpc {
  unsigned long magic;
  struct hpc_shared sh;
  hpc_real last_steer, cost;
  int solver_code, iterations, converged; /* the last solve's */
  int ocp;                                /* the OCP of the last solve (its plan) */
  /* the path tracked (hitchpark_nmpc_follow; path_n 0: park at the goal), PathReference's */
  int path_n;
  hpc_real path[5][HITCHPARK_NMPC_MAX_PATH]; /* x, y, yaw, hitch, steer, parking frame */
  hpc_real path_s[HITCHPARK_NMPC_MAX_PATH];  /* arc length */
  hpc_real speed, brake, length, progress, deviation;
  hitchpark_nmpc_pose goal; /* the goal of this tick */
#if HPC_OBSTACLES
  /* the scene kept clear of (hitchpark_nmpc_keep_clear; n_pieces 0: open space): convex pieces, each padded to
     `size` vertices with its last (obstacles._padded), in the world frame and in the goal's (framed) */
  int n_pieces, size, framed;
  hitchpark_nmpc_pose framed_goal;
  hpc_real clearance, base_clearance;
  hpc_real world[HITCHPARK_NMPC_MAX_PIECES * HITCHPARK_NMPC_MAX_VERTICES * 2];
  hpc_real vertices[HITCHPARK_NMPC_MAX_PIECES * HITCHPARK_NMPC_MAX_VERTICES * 2];
  hpc_real edges[HITCHPARK_NMPC_MAX_PIECES * HITCHPARK_NMPC_MAX_VERTICES * 4];
  hpc_real outward[HITCHPARK_NMPC_MAX_PIECES * HITCHPARK_NMPC_MAX_VERTICES * 2];
  hpc_real real_edge[HITCHPARK_NMPC_MAX_PIECES * HITCHPARK_NMPC_MAX_VERTICES];
  hpc_real scratch[HITCHPARK_NMPC_MAX_PIECES * (11 + HITCHPARK_NMPC_MAX_VERTICES)];
  hpc_real states[(HPC_N + 1) * HPC_NX];          /* X_0..X_N the lines are drawn around */
  hpc_real guess[HPC_NW], start[HPC_NW], iterate[HPC_NW]; /* a cold start's */
#endif
  HPC_OCPS(HPC_BLOCK)
};
#undef HPC_BLOCK

/* The OCPs, in the order of HPC_OCPS, and where each one's block lies. */
#define HPC_INDEX(name) HPC_OCP_##name,
enum { HPC_OCPS(HPC_INDEX) HPC_N_OCPS };
#undef HPC_INDEX
#define HPC_ENTRY(name) {hpc_##name##_cascade, hpc_##name##_solve_from, hpc_##name##_plan, hpc_##name##_report},
static const struct hpc_ocp hpc_ocps[HPC_N_OCPS] = {HPC_OCPS(HPC_ENTRY)};
#undef HPC_ENTRY
#define HPC_OFFSET(name) offsetof(struct hitchpark_nmpc, name),
static const size_t hpc_offsets[HPC_N_OCPS] = {HPC_OCPS(HPC_OFFSET)};
#undef HPC_OFFSET

/* C99's static assertion: the workspace the header promises holds the controller. */
typedef char hpc_workspace_fits[sizeof(struct hitchpark_nmpc) <= HITCHPARK_NMPC_WORKSPACE_BYTES ? 1 : -1];

static void* hpc_block(struct hitchpark_nmpc* c, int ocp) { return (unsigned char*) c + hpc_offsets[ocp]; }

static const void* hpc_block_const(const struct hitchpark_nmpc* c, int ocp) {
  return (const unsigned char*) c + hpc_offsets[ocp];
}

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
static hpc_real hpc_clamp(hpc_real v, hpc_real lo, hpc_real hi) {
  if (lo > v) v = lo;
  if (hi < v) v = hi;
  return v;
}

hpc_real hpc_clip(hpc_real v, hpc_real lo, hpc_real hi) {
  if (!isnan(v)) v = v > lo ? v : lo;
  if (!isnan(v)) v = v < hi ? v : hi;
  return v;
}

/* Python's float modulo (the sign of the divisor). */
static hpc_real hpc_mod(hpc_real a, hpc_real b) {
  hpc_real r = fmod(a, b);
  if (r != 0.0) {
    if ((b < 0.0) != (r < 0.0)) r += b;
  } else {
    r = copysign(0.0, b);
  }
  return r;
}

/* An angle wrapped to [-pi, pi) (hitchpark.model.state.wrap_angle). */
static hpc_real hpc_wrap(hpc_real a) {
  hpc_real w = hpc_mod(a + HPC_PI, 2.0 * HPC_PI) - HPC_PI;
  return w >= HPC_PI ? w - 2.0 * HPC_PI : w;
}

int hpc_finite(const hpc_real* v, int n) {
  int i;
  for (i = 0; i < n; ++i)
    if (!isfinite(v[i])) return 0;
  return 1;
}

void hpc_call(struct hpc_shared* sh, hpc_function f, const hpc_real* x, const hpc_real* u, hpc_real* out) {
  sh->arg[0] = x;
  sh->arg[1] = u;
  sh->res[0] = out;
  f(sh->arg, sh->res, sh->iw, sh->w, 0);
}

hpc_real hpc_next_first_step(const struct hpc_shared* sh, hpc_real* part) {
  hpc_real left;
  if (!sh->first_param) { /* equal steps from each sample: the plan moves on a sample's part of a step */
    *part = HPC_DT / HPC_PREDICTION_DT;
    return HPC_PREDICTION_DT;
  }
  *part = 1.0;
  if (!sh->has_last) return HPC_PREDICTION_DT;
  left = sh->first_step - HPC_DT;
  if (left >= HPC_DT - 1e-9) {
    *part = 0.0;
    return left;
  }
  return left + HPC_PREDICTION_DT;
}

/* The state the next command will act on, in the parking frame (FullNMPC._state). */
static void hpc_state(struct hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas, const hitchpark_nmpc_pose* goal,
                      const hitchpark_nmpc_command* in_flight, int n_in_flight, hpc_real* x) {
  hpc_real cg = cos(goal->yaw), sg = sin(goal->yaw);
  hpc_real ex = meas->x - goal->x, ey = meas->y - goal->y;
  int i, j;
  x[0] = cg * ex + sg * ey;
  x[1] = -sg * ex + cg * ey;
  x[2] = hpc_wrap(meas->yaw - goal->yaw);
  x[3] = meas->hitch;
  x[4] = meas->front_steer;
  x[5] = meas->rear_speed;
  for (i = 0; i < n_in_flight; ++i) {
    hpc_real u[2], next[HPC_NX];
    u[0] = hpc_clip((in_flight[i].front_steer - x[HPC_STEER]) / HPC_DT, -HPC_MAX_STEER_RATE, HPC_MAX_STEER_RATE);
    u[1] = hpc_clip((in_flight[i].rear_speed - x[HPC_SPEED]) / HPC_DT, -HPC_MAX_ACCEL, HPC_MAX_ACCEL);
    hpc_call(&c->sh, HPC_MODEL_STEP, x, u, next);
    for (j = 0; j < HPC_NX; ++j) x[j] = next[j];
  }
}

#include "hitchpark_nmpc_path.inc" /* the path (PathReference) */

/* The OCP of the moment (FullNMPC._program_for): tracking a path or not, among obstacles or not. */
static void hpc_choose(struct hitchpark_nmpc* c) {
#if HPC_OBSTACLES
  if (c->n_pieces > 0) {
    c->ocp = c->path_n > 0 ? HPC_OCP_track_lines : HPC_OCP_park_lines;
    c->sh.first_param = 0;
    return;
  }
#endif
  c->ocp = c->path_n > 0 ? HPC_OCP_track : HPC_OCP_park;
  c->sh.first_param = 1;
}

/* The solve cascade of the OCP of the moment; its codes kept. */
static int hpc_cascade(struct hitchpark_nmpc* c, const hpc_real* x0, int free) {
  struct hpc_report r;
  int code;
  code = hpc_ocps[c->ocp].cascade(hpc_block(c, c->ocp), &c->sh, x0, free);
  hpc_ocps[c->ocp].report(hpc_block(c, c->ocp), &r);
  c->solver_code = r.solver_code;
  c->iterations = r.iterations;
  c->converged = r.converged;
  c->cost = r.cost;
  return code;
}

static const hpc_real* hpc_plan(const struct hitchpark_nmpc* c) {
  return hpc_ocps[c->ocp].plan(hpc_block_const(c, c->ocp));
}

#include "hitchpark_nmpc_scene.inc" /* the scene (ClearanceConstraints) */

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

size_t hitchpark_nmpc_workspace_bound(void) { return HITCHPARK_NMPC_WORKSPACE_BYTES; }

hitchpark_nmpc* hitchpark_nmpc_init(void* memory, size_t bytes) {
  struct hitchpark_nmpc* c = (struct hitchpark_nmpc*) memory;
  if (!memory || bytes < sizeof(struct hitchpark_nmpc) || (uintptr_t) memory % sizeof(double) != 0) return 0;
  memset(c, 0, sizeof(*c));
  c->magic = HPC_MAGIC;
  c->sh.first_step = HPC_PREDICTION_DT;
  c->sh.first_now = HPC_PREDICTION_DT;
  c->cost = NAN;
  return c;
}

int hitchpark_nmpc_reset(hitchpark_nmpc* c, hitchpark_real front_steer) {
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  c->sh.has_last = 0;
  c->last_steer = isfinite(front_steer) ? front_steer : 0.0;
  return 0;
}

int hitchpark_nmpc_follow(hitchpark_nmpc* c, const hitchpark_real* path, int n, hitchpark_real speed,
                          hitchpark_real max_accel) {
  int i, j;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (n < 0 || n > HITCHPARK_NMPC_MAX_PATH) return HITCHPARK_NMPC_E_ARGUMENT;
  if (n > 0 && !path) return HITCHPARK_NMPC_E_NULL;
  if (n > 0 && (!hpc_finite(path, 5 * n) || !(speed > 0.0) || !isfinite(speed) || !(max_accel > 0.0) ||
                !isfinite(max_accel)))
    return HITCHPARK_NMPC_E_ARGUMENT;
  for (i = 0; i < n; ++i)
    for (j = 0; j < 5; ++j) c->path[j][i] = path[5 * i + j];
  for (i = 0; i < n; ++i) /* np.cumsum of np.hypot of the steps */
    c->path_s[i] = i == 0 ? 0.0 : c->path_s[i - 1] + hypot(c->path[0][i] - c->path[0][i - 1], c->path[1][i] - c->path[1][i - 1]);
  c->path_n = n;
  c->length = n > 0 ? c->path_s[n - 1] : 0.0;
  c->speed = speed;
  c->brake = 0.5 * max_accel;
  c->progress = c->deviation = 0.0; /* PathReference.reset */
  c->sh.has_last = 0;               /* FullNMPC.follow resets the controller */
  return 0;
}

int hitchpark_nmpc_keep_clear(hitchpark_nmpc* c, const hitchpark_real* vertices, const int* counts, int n_pieces,
                              hitchpark_real clearance) {
#if HPC_OBSTACLES
  int j, v, at = 0, size = 0;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (n_pieces < 0 || n_pieces > HITCHPARK_NMPC_MAX_PIECES || !(clearance >= 0.0 && clearance <= 10.0))
    return HITCHPARK_NMPC_E_ARGUMENT;
  if (n_pieces > 0 && (!vertices || !counts)) return HITCHPARK_NMPC_E_NULL;
  for (j = 0; j < n_pieces; ++j) {
    if (counts[j] < 3 || counts[j] > HITCHPARK_NMPC_MAX_VERTICES) return HITCHPARK_NMPC_E_ARGUMENT;
    if (!hpc_finite(vertices + 2 * at, 2 * counts[j])) return HITCHPARK_NMPC_E_ARGUMENT;
    at += counts[j];
    if (counts[j] > size) size = counts[j];
  }
  at = 0;
  for (j = 0; j < n_pieces; ++j) { /* each piece padded with its last vertex (obstacles._padded) */
    for (v = 0; v < size; ++v) {
      int from = at + (v < counts[j] ? v : counts[j] - 1);
      c->world[2 * (size * j + v)] = vertices[2 * from];
      c->world[2 * (size * j + v) + 1] = vertices[2 * from + 1];
      c->real_edge[size * j + v] = v < counts[j] - 1 || v == size - 1;
    }
    at += counts[j];
  }
  c->n_pieces = n_pieces;
  c->size = size;
  c->framed = 0;
  c->clearance = c->base_clearance = clearance;
  c->sh.has_last = 0; /* FullNMPC.keep_clear resets the controller */
  return 0;
#else
  (void) vertices, (void) counts, (void) clearance;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  return n_pieces == 0 ? 0 : HITCHPARK_NMPC_E_ARGUMENT; /* exported without the obstacle OCP */
#endif
}

int hitchpark_nmpc_ease_clearance(hitchpark_nmpc* c, hitchpark_real clearance) {
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (!isfinite(clearance)) return HITCHPARK_NMPC_E_ARGUMENT;
#if HPC_OBSTACLES
  c->clearance = clearance < c->base_clearance ? clearance : c->base_clearance; /* min(base, clearance) */
#endif
  return 0;
}

int hitchpark_nmpc_hold_clearance(hitchpark_nmpc* c, hitchpark_real clearance) {
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (!isfinite(clearance) || clearance < 0) return HITCHPARK_NMPC_E_ARGUMENT;
#if HPC_OBSTACLES
  c->clearance = clearance;
#endif
  return 0;
}

int hitchpark_nmpc_path_progress(const hitchpark_nmpc* c, hitchpark_real* progress, hitchpark_real* deviation) {
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  if (progress) *progress = c->progress;
  if (deviation) *deviation = c->deviation;
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
static int hpc_refused(const hpc_real* x) {
  if (!hpc_finite(x, HPC_NX)) return HITCHPARK_NMPC_E_STATE;
  if (fabs(x[3]) > HPC_MAX_HITCH) return HITCHPARK_NMPC_E_HITCH;
  return 0;
}

static void hpc_clear(struct hitchpark_nmpc* c) {
  c->solver_code = 0;
  c->iterations = 0;
  c->converged = 0;
  c->cost = NAN;
}

int hitchpark_nmpc_step(hitchpark_nmpc* c, const hitchpark_nmpc_measurement* meas, const hitchpark_nmpc_pose* goal,
                        const hitchpark_nmpc_command* in_flight, int n_in_flight, hitchpark_nmpc_command* command_out,
                        hitchpark_nmpc_status* status_out) {
  long long t0 = hpc_now_ns();
  hpc_real* x0;
  hpc_real steer = 0.0, speed = 0.0;
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
  hpc_clear(c);
  hpc_choose(c);
  c->goal = *goal;
  x0 = c->sh.x0;
  hpc_state(c, meas, goal, in_flight, n_in_flight, x0);
  code = hpc_refused(x0);
  if (code == 0) {
    hpc_track(c, x0);
    code = hpc_cascade(c, x0, 0);
  }
  if (code == 0) {
    const hpc_real* u0 = hpc_plan(c) + HPC_NX;
    steer = hpc_clamp(x0[HPC_STEER] + HPC_DT * u0[0], -HPC_MAX_STEER, HPC_MAX_STEER);
    speed = hpc_clamp(x0[HPC_SPEED] + HPC_DT * u0[1], HPC_SPEED_MIN, HPC_SPEED_MAX);
    if (!isfinite(steer) || !isfinite(speed)) code = HITCHPARK_NMPC_E_COMMAND;
  }
  if (code != 0) { /* RecedingHorizon._stop */
    c->sh.has_last = 0;
    command_out->rear_speed = 0.0;
    command_out->front_steer = c->last_steer;
    hpc_status(status_out, c, code, 1, t0);
    return code;
  }
  stop = fabs(speed) < HPC_STOP_SPEED && fabs(x0[HPC_SPEED]) < HPC_STOP_SPEED;
  memcpy(c->sh.last_w, hpc_plan(c), sizeof(c->sh.last_w));
  c->sh.has_last = 1;
  c->sh.first_step = c->sh.first_now;
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
  int code = hpc_checked(c, meas, goal, 0, 0);
  if (code == 0 && !steer_out) code = HITCHPARK_NMPC_E_NULL;
  if (code != 0) {
    hpc_status(status_out, hpc_valid(c) ? c : 0, code, 1, t0);
    return code;
  }
  hpc_clear(c);
  hpc_choose(c);
  c->goal = *goal;
  hpc_state(c, meas, goal, 0, 0, c->sh.x0);
  code = hpc_refused(c->sh.x0);
  if (code != 0) {
    c->sh.has_last = 0;
  } else {
    hpc_track(c, c->sh.x0);
    code = hpc_cascade(c, c->sh.x0, 1);
    if (code == 0) {
      const hpc_real* plan = hpc_plan(c);
      hpc_real steer = hpc_clamp(c->sh.x0[HPC_STEER] + HPC_DT * plan[HPC_NX], -HPC_MAX_STEER, HPC_MAX_STEER);
      hpc_real speed = hpc_clamp(c->sh.x0[HPC_SPEED] + HPC_DT * plan[HPC_NX + 1], HPC_SPEED_MIN, HPC_SPEED_MAX);
      if (!isfinite(steer) || !isfinite(speed)) code = HITCHPARK_NMPC_E_COMMAND;
      else c->sh.first_step = c->sh.first_now;
    }
    /* FullNMPC.initial_steer resets the controller to the measured steer whatever the answer */
    c->sh.has_last = 0;
    c->last_steer = meas->front_steer;
    if (code == 0) *steer_out = hpc_clamp(hpc_plan(c)[HPC_STEER], -HPC_MAX_STEER, HPC_MAX_STEER);
  }
  hpc_status(status_out, c, code, 0, t0);
  return code;
}

int hitchpark_nmpc_prediction(const hitchpark_nmpc* c, hitchpark_real* states, hitchpark_real* inputs) {
  const hpc_real* plan;
  int k, i;
  if (!hpc_valid(c)) return HITCHPARK_NMPC_E_WORKSPACE;
  plan = hpc_plan(c);
  for (k = 0; k <= HPC_N; ++k) {
    for (i = 0; i < HPC_NX; ++i)
      if (states) states[k * HPC_NX + i] = plan[k * HPC_NV + i];
    for (i = 0; i < HPC_NU && k < HPC_N; ++i)
      if (inputs) inputs[k * HPC_NU + i] = plan[k * HPC_NV + HPC_NX + i];
  }
  return 0;
}

int hitchpark_nmpc_state(const hitchpark_nmpc* c, hitchpark_real* x0) {
  int i;
  if (!hpc_valid(c) || !x0) return HITCHPARK_NMPC_E_WORKSPACE;
  for (i = 0; i < HPC_NX; ++i) x0[i] = c->sh.x0[i];
  return 0;
}

const char* hitchpark_nmpc_message(int code) {
  if (code < 0 || code >= (int) (sizeof(hpc_messages) / sizeof(hpc_messages[0]))) return "unknown error code";
  return hpc_messages[code];
}
