/* examples/main.c: one reverse stage of hitchpark's maneuver in closed loop, printed as CSV.
 *
 * The plant is hitchpark's ideal one for the scenario this package was exported with (example_scenario.h):
 * the command acts at once (after the plant's delay, in samples) and is held for the sample, the full
 * kinematics integrated by RK4 (example_plant.c, generated from hitchpark's own plant function). The stage
 * runs as hitchpark's does (hitchpark.maneuver.loop.run_stage): the wheels turned to the controller's
 * initial steer standing still, then sense, step, apply until the plan stops, a brake, a last row.
 * Each row: t [s], the trailer axle's x, y [m], yaw [rad], the hitch angle [rad], the acting steer [rad] and
 * speed [m/s], the commanded steer and speed, the error code and the step's time [ns]. Exit status: 0 parked
 * within 5 cm, 1 not, 2 a failure.
 */
#include <math.h>
#include <stdio.h>
#include "hitchpark_nmpc.h"
#include "example_scenario.h"

int hitchpark_example_plant(const hitchpark_real** arg, hitchpark_real** res, long long int* iw, hitchpark_real* w,
                            int mem);

typedef struct {
  hitchpark_real x[4];   /* trailer x, y, yaw, hitch */
  hitchpark_real steer, speed, t;
  hitchpark_nmpc_command queue[EX_DELAY + 2]; /* commands issued, oldest first: the plant's delay */
  int queued;
  hitchpark_nmpc_command issued[EX_DELAY + 2]; /* the last commands issued (the controller's in flight) */
  int n_issued;
  hitchpark_nmpc_command last;
} plant_t;

static hitchpark_real clampr(hitchpark_real v, hitchpark_real lo, hitchpark_real hi) {
  if (lo > v) v = lo;
  if (hi < v) v = hi;
  return v;
}

static void print_row(const plant_t* p, hitchpark_nmpc_command acting, hitchpark_nmpc_command cmd, int code, long long ns) {
  printf("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%lld\n", (double) p->t, (double) p->x[0],
         (double) p->x[1], (double) p->x[2], (double) p->x[3], (double) acting.front_steer, (double) acting.rear_speed,
         (double) cmd.front_steer, (double) cmd.rear_speed, code, ns);
}

/* Apply one command for a sample (hitchpark's Plant.apply, ideal); 0 on a jackknife (nothing moved). */
static int apply(plant_t* p, hitchpark_nmpc_command cmd, int code, long long ns) {
  hitchpark_real u[2], next[4], dt = EX_DT;
  const hitchpark_real* arg[3];
  hitchpark_real* res[1];
  hitchpark_real w[EX_PLANT_SZ_W];
  long long int iw[EX_PLANT_SZ_IW];
  hitchpark_nmpc_command acted, acting;
  int i;
  cmd.front_steer = clampr(cmd.front_steer, -EX_PLANT_MAX_STEER, EX_PLANT_MAX_STEER);
  p->queue[p->queued++] = cmd;
  acted = p->queue[0];
  acting.rear_speed = acted.rear_speed;
  acting.front_steer = clampr(acted.front_steer, -EX_PLANT_MAX_STEER, EX_PLANT_MAX_STEER);
  u[0] = acting.rear_speed;
  u[1] = acting.front_steer;
  arg[0] = p->x;
  arg[1] = u;
  arg[2] = &dt;
  res[0] = next;
  hitchpark_example_plant(arg, res, iw, w, 0);
  if (!(fabs(next[3]) <= EX_PLANT_MAX_HITCH)) {
    --p->queued;
    return 0;
  }
  for (i = 1; i < p->queued; ++i) p->queue[i - 1] = p->queue[i];
  --p->queued;
  print_row(p, acting, cmd, code, ns);
  for (i = 0; i < 4; ++i) p->x[i] = next[i];
  p->steer = acting.front_steer;
  p->speed = acting.rear_speed;
  p->t += EX_DT;
  /* the commands in flight: the last EX_DELAY issued */
  if (p->n_issued == EX_DELAY + 1) {
    for (i = 1; i < p->n_issued; ++i) p->issued[i - 1] = p->issued[i];
    --p->n_issued;
  }
  p->issued[p->n_issued++] = cmd;
  p->last = cmd;
  return 1;
}

static hitchpark_nmpc_measurement sense(const plant_t* p) {
  hitchpark_nmpc_measurement m;
  m.x = p->x[0];
  m.y = p->x[1];
  m.yaw = p->x[2];
  m.hitch = p->x[3];
  m.front_steer = p->steer;
  m.rear_speed = p->speed;
  return m;
}

static int stopped(plant_t* p) {
  int i;
  for (i = 0; i < p->queued; ++i)
    if (p->queue[i].rear_speed != 0.0) return 0;
  p->speed = 0.0;
  return 1;
}

static int out_of_time(const plant_t* p) { return p->t >= EX_MAX_TIME - 1e-9; }

int main(void) {
  static hitchpark_nmpc_workspace memory; /* the example's one controller: static storage, not the heap */
  hitchpark_nmpc* nmpc = hitchpark_nmpc_init(&memory, sizeof(memory));
  hitchpark_nmpc_pose goal;
  hitchpark_nmpc_status status;
  hitchpark_nmpc_measurement m;
  hitchpark_nmpc_command cmd, none = {0.0, 0.0};
  hitchpark_real want;
  plant_t p;
  int i, step, failed = 0, timeout = 0;
  double dx, dy;
  if (!nmpc) return 2;
  p.x[0] = EX_START_X;
  p.x[1] = EX_START_Y;
  p.x[2] = EX_START_YAW;
  p.x[3] = EX_START_HITCH;
  p.steer = p.speed = p.t = 0.0;
  p.queued = p.n_issued = 0;
  p.last = none;
  for (i = 0; i < EX_DELAY; ++i) p.queue[p.queued++] = none;
  goal.x = EX_GOAL_X;
  goal.y = EX_GOAL_Y;
  goal.yaw = EX_GOAL_YAW;
  printf("t,x_trailer,y_trailer,yaw_trailer,hitch,front_steer,rear_speed,front_steer_cmd,rear_speed_cmd,error,step_ns\n");
  /* the stage's start: reset, the initial steer, the wheels turned to it standing still */
  m = sense(&p);
  hitchpark_nmpc_reset(nmpc, m.front_steer);
  if (hitchpark_nmpc_initial_steer(nmpc, &m, &goal, &want, &status) == HITCHPARK_NMPC_OK) {
    hitchpark_real rate = EX_STEER_RATE * EX_DT;
    want = clampr(want, -EX_PLANT_MAX_STEER, EX_PLANT_MAX_STEER);
    while (fabs(p.steer - want) > EX_SETTLE_TOLERANCE || p.last.front_steer != want) {
      if (out_of_time(&p)) return 2;
      cmd.rear_speed = 0.0;
      cmd.front_steer = p.last.front_steer + clampr(want - p.last.front_steer, -rate, rate);
      if (!apply(&p, cmd, 0, 0)) return 2;
    }
  }
  /* sense, step, apply until the plan stops */
  for (step = 0; step < EX_MAX_STEPS; ++step) {
    hitchpark_real steer_step = EX_STEER_RATE * EX_DT, speed_step = EX_ACCEL * EX_DT;
    int n = p.n_issued < EX_DELAY ? p.n_issued : EX_DELAY;
    if (out_of_time(&p)) {
      timeout = 1;
      break;
    }
    m = sense(&p);
    if (hitchpark_nmpc_step(nmpc, &m, &goal, p.issued + (p.n_issued - n), n, &cmd, &status) != HITCHPARK_NMPC_OK) {
      fprintf(stderr, "step %d: %s\n", step, status.message);
      failed = 1;
      break;
    }
    if (status.stop) break;
    /* within the steer-rate and acceleration limits of the last command (hitchpark's ClosedLoop.limited) */
    cmd.rear_speed = clampr(cmd.rear_speed, p.last.rear_speed - speed_step, p.last.rear_speed + speed_step);
    cmd.front_steer = clampr(cmd.front_steer, p.last.front_steer - steer_step, p.last.front_steer + steer_step);
    if (!apply(&p, cmd, status.error, status.solve_time_ns)) return 2;
  }
  /* the brake: commands in flight still act */
  while (!timeout && !stopped(&p)) {
    cmd.rear_speed = 0.0;
    cmd.front_steer = p.last.front_steer;
    if (out_of_time(&p) || !apply(&p, cmd, 0, 0)) return 2;
  }
  cmd.rear_speed = 0.0;
  cmd.front_steer = p.last.front_steer;
  {
    hitchpark_nmpc_command acting;
    acting.rear_speed = 0.0;
    acting.front_steer = p.steer;
    print_row(&p, acting, cmd, 0, 0);
  }
  dx = p.x[0] - EX_GOAL_X;
  dy = p.x[1] - EX_GOAL_Y;
  if (failed || timeout) return 2;
  return sqrt(dx * dx + dy * dy) <= 0.05 ? 0 : 1;
}
