/* The exported controller's allocations, counted by an interposed allocator (the test of test_package.py).
 *
 * This program defines malloc, calloc, realloc and free itself, forwarding to glibc's own (__libc_malloc...):
 * the C library's calls go through the program's definitions too, so every allocation of the process is
 * counted. It initialises one controller, then drives 2000 steps in closed loop on the example's plant from the
 * example's start (starting again at each stop), every 97th with a measurement that is not finite (the error
 * path). It prints three counts: after init, after the steps, and after one malloc of its own (the counter's
 * own check: it must be one more). Built with -fno-builtin: GCC takes malloc for the C library's and would
 * otherwise drop the pair malloc, free of the check.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include "hitchpark_nmpc.h"
#include "example_scenario.h"

static volatile long allocations = 0; /* volatile: read afresh after every call */

#ifndef NOT_COUNTED /* -DNOT_COUNTED: the same loop under the sanitizers, which bring their own allocator */
extern void* __libc_malloc(size_t size);
extern void* __libc_calloc(size_t n, size_t size);
extern void* __libc_realloc(void* p, size_t size);
extern void __libc_free(void* p);

void* malloc(size_t size) { ++allocations; return __libc_malloc(size); }
void* calloc(size_t n, size_t size) { ++allocations; return __libc_calloc(n, size); }
void* realloc(void* p, size_t size) { ++allocations; return __libc_realloc(p, size); }
void free(void* p) { __libc_free(p); }
#else
#include <stdlib.h>
#endif

int hitchpark_example_plant(const hitchpark_real** arg, hitchpark_real** res, long long int* iw, hitchpark_real* w,
                            int mem);

static hitchpark_nmpc_workspace memory;

int main(void) {
  hitchpark_nmpc* nmpc = hitchpark_nmpc_init(&memory, sizeof(memory));
  hitchpark_nmpc_pose goal = {EX_GOAL_X, EX_GOAL_Y, EX_GOAL_YAW};
  hitchpark_nmpc_measurement m;
  hitchpark_nmpc_command cmd;
  hitchpark_nmpc_status status;
  hitchpark_real x[4], next[4], u[2], dt = EX_DT, w[EX_PLANT_SZ_W];
  long long int iw[EX_PLANT_SZ_IW];
  const hitchpark_real* arg[3];
  hitchpark_real* res[1];
  long after_init, after_steps;
  int step, solved = 0, refused = 0, restart = 1;
  void* volatile mine;
  if (!nmpc) return 2;
  after_init = allocations;
  for (step = 0; step < 2000; ++step) {
    if (restart) {
      x[0] = EX_START_X; x[1] = EX_START_Y; x[2] = EX_START_YAW; x[3] = EX_START_HITCH;
      m.front_steer = 0.0;
      m.rear_speed = 0.0;
      hitchpark_nmpc_reset(nmpc, 0.0);
      restart = 0;
    }
    m.x = x[0]; m.y = x[1]; m.yaw = x[2]; m.hitch = step % 97 == 96 ? NAN : x[3];
    if (hitchpark_nmpc_step(nmpc, &m, &goal, NULL, 0, &cmd, &status) != HITCHPARK_NMPC_OK) {
      ++refused;
      continue;
    }
    ++solved;
    if (status.stop) { restart = 1; continue; }
    u[0] = cmd.rear_speed; u[1] = cmd.front_steer;
    arg[0] = x; arg[1] = u; arg[2] = &dt; res[0] = next;
    hitchpark_example_plant(arg, res, iw, w, 0);
    x[0] = next[0]; x[1] = next[1]; x[2] = next[2]; x[3] = next[3];
    m.front_steer = cmd.front_steer;
    m.rear_speed = cmd.rear_speed;
  }
  after_steps = allocations;
  mine = malloc(16);
  free(mine);
  printf("%ld %ld %ld %d %d\n", after_init, after_steps, allocations, solved, refused);
  return 0;
}
