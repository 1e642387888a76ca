/* Compiled cable callback: the laws of _laws.py, run by MuJoCo inside its own step.
 *
 * Installed as mjcb_control, it runs once per mj_step (Euler integrator), after positions and
 * velocities are known and before actuation. For each MjData registered with a context it:
 *   1. advances each motor's rest length (only when time has moved on since the last call, so an
 *      extra mj_forward does not move motors), toward an impedance-law target or a commanded
 *      rest length, under the motor's speed, force and floor limits;
 *   2. computes each cable's tension (paper eq. 1-2) and writes -tension into its actuator's ctrl;
 *   3. applies the scheduled external forces at node points (xfrc_applied).
 * No MuJoCo function is called (only its structs are read), so nothing links against it.
 * Every operation mirrors _laws.py in the same order, so the two agree to rounding.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <string.h>

#include <mujoco/mujoco.h>

#define TENSIM_MAX_CONTEXTS 1024

typedef struct {
  mjData* data;
  int ncable;
  const int* tendon;
  const int* actuator;
  /* cable and motor parameters, (ncable,) */
  const double* stiffness;
  const double* damping;
  const double* max_speed;
  const double* max_tension;
  const double* min_rest;
  const double* min_length;
  /* control, (ncable,): mode 0 = commanded rest length, 1 = impedance law */
  const int* mode;
  const double* rest_command;
  const double* offset_tension;
  const double* gain_k;
  const double* gain_b;
  const double* target_length;
  /* target velocity V*: (vstar_rows, ncable) table, row r holds t in [r, r+1) * vstar_dt */
  const double* vstar;
  int vstar_rows;
  double vstar_dt;
  /* state and outputs, (ncable,) */
  double* rest;
  double* tension;
  double* applied;
  double* setpoint;
  double* peak;      /* running maximum of the load-cell tension */
  double* last_time; /* (1,) time of the last motor update, -inf before the first */
  /* external loads: body id, point in body frame (3), knots [start, start + count) */
  int nload;
  const int* load_body;
  const double* load_point;
  const int* load_start;
  const int* load_count;
  const double* knot_time;
  const double* knot_force; /* (nknot, 3) [N] */
} tensim_context;

static tensim_context* contexts[TENSIM_MAX_CONTEXTS];
static int ncontext = 0;

int tensim_register(tensim_context* ctx) {
  for (int i = 0; i < ncontext; i++) {
    if (contexts[i]->data == ctx->data) {
      contexts[i] = ctx;
      return 0;
    }
  }
  if (ncontext >= TENSIM_MAX_CONTEXTS) return -1;
  contexts[ncontext++] = ctx;
  return 0;
}

void tensim_unregister(void* data) {
  for (int i = 0; i < ncontext; i++) {
    if ((void*)contexts[i]->data == data) {
      contexts[i] = contexts[--ncontext];
      return;
    }
  }
}

int tensim_header_version(void) { return mjVERSION_HEADER; }

static double vstar_at(const tensim_context* c, double t, int i) {
  if (!c->vstar || c->vstar_rows <= 0) return 0.0;
  long row = (long)floor(t / c->vstar_dt + 1e-9);
  if (row < 0) row = 0;
  if (row >= c->vstar_rows) row = c->vstar_rows - 1;
  return c->vstar[row * c->ncable + i];
}

static void advance_motors(const tensim_context* c, const mjData* d, double dt) {
  for (int i = 0; i < c->ncable; i++) {
    double x = d->ten_length[c->tendon[i]];
    double v = d->ten_velocity[c->tendon[i]];
    double k = c->stiffness[i];
    double rest = c->rest[i];
    double stretch = x - rest;
    double measured = stretch > 0.0 ? k * stretch : 0.0;
    double target;
    if (c->mode[i] == 1) {
      double set = c->offset_tension[i] + c->gain_k[i] * (x - c->target_length[i])
                   + c->gain_b[i] * (v - vstar_at(c, d->time, i));
      set = fmax(0.0, set);
      c->setpoint[i] = set;
      target = rest - (set - measured) / k;
    } else {
      c->setpoint[i] = NAN;
      target = c->rest_command[i];
    }
    double reach = c->max_speed[i] * dt;
    double step = fmin(fmax(target - rest, -reach), reach);
    double next = rest + step;
    if (step < 0.0) {
      double force_floor = fmin(rest, x - c->max_tension[i] / k);
      next = fmax(next, force_floor);
      if (x <= c->min_length[i]) next = rest;
    }
    c->rest[i] = fmax(next, c->min_rest[i]);
  }
}

static void apply_tensions(const tensim_context* c, mjData* d) {
  for (int i = 0; i < c->ncable; i++) {
    double x = d->ten_length[c->tendon[i]];
    double v = d->ten_velocity[c->tendon[i]];
    double stretch = x - c->rest[i];
    double spring = 0.0, applied = 0.0;
    if (stretch > 0.0) {
      spring = c->stiffness[i] * stretch;
      applied = fmax(spring + c->damping[i] * v, 0.0);
    }
    c->tension[i] = spring;
    c->peak[i] = fmax(c->peak[i], spring);
    c->applied[i] = applied;
    d->ctrl[c->actuator[i]] = -applied;
  }
}

static void apply_loads(const tensim_context* c, mjData* d) {
  for (int j = 0; j < c->nload; j++) {
    memset(d->xfrc_applied + 6 * c->load_body[j], 0, 6 * sizeof(mjtNum));
  }
  for (int j = 0; j < c->nload; j++) {
    int b = c->load_body[j], start = c->load_start[j], count = c->load_count[j];
    const double* kt = c->knot_time + start;
    const double* kf = c->knot_force + 3 * start;
    double f[3] = {0, 0, 0};
    double t = d->time;
    if (t <= kt[0]) {
      for (int a = 0; a < 3; a++) f[a] = kf[a];
    } else if (t >= kt[count - 1]) {
      for (int a = 0; a < 3; a++) f[a] = kf[3 * (count - 1) + a];
    } else {
      int k = 0;
      while (k + 1 < count && kt[k + 1] <= t) k++;
      double s = (t - kt[k]) / (kt[k + 1] - kt[k]);
      for (int a = 0; a < 3; a++) f[a] = kf[3 * k + a] + s * (kf[3 * (k + 1) + a] - kf[3 * k + a]);
    }
    /* force at the node point, moved to the body's centre of mass as force + torque */
    const double* R = d->xmat + 9 * b;
    const double* q = c->load_point + 3 * j;
    double arm[3];
    for (int a = 0; a < 3; a++) {
      arm[a] = R[3 * a] * q[0] + R[3 * a + 1] * q[1] + R[3 * a + 2] * q[2]
               + d->xpos[3 * b + a] - d->xipos[3 * b + a];
    }
    double* out = d->xfrc_applied + 6 * b;
    out[0] += f[0];
    out[1] += f[1];
    out[2] += f[2];
    out[3] += arm[1] * f[2] - arm[2] * f[1];
    out[4] += arm[2] * f[0] - arm[0] * f[2];
    out[5] += arm[0] * f[1] - arm[1] * f[0];
  }
}

void tensim_control(const mjModel* m, mjData* d) {
  tensim_context* c = NULL;
  for (int i = 0; i < ncontext; i++) {
    if (contexts[i]->data == d) {
      c = contexts[i];
      break;
    }
  }
  if (!c) return;
  if (d->time > c->last_time[0]) {
    advance_motors(c, d, m->opt.timestep);
    c->last_time[0] = d->time;
  }
  apply_tensions(c, d);
  apply_loads(c, d);
}

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cable",
                             "Compiled tensim cable callback (loaded through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__cable(void) { return PyModule_Create(&module); }
