/* Compiled cable law: the laws of _laws.py as MuJoCo user-actuator callbacks.
 *
 * Each cable is one MuJoCo actuator on its tendon with user dynamics, zero gain and user bias.
 * Everything the law needs lives in the model and the data, so the callbacks keep no state and
 * are safe to run from many threads at once (mujoco.rollout, mujoco.batch):
 *   act[adr]     rest length l [m]              act[adr + 1]  peak load-cell tension [N]
 *   act[adr + 2] DC motors only (actdim 3): the spool's line speed dl/dt [m/s]
 *   ctrl[cadr]   V* [m/s] (impedance mode) or the commanded rest length [m] (rest mode)
 *   dynprm       [marker, mode, max_speed, max_tension, min_rest, min_length, T0, K, B, L*]
 *   biasprm      [stiffness k, damping b, 0, and for DC motors: stall force F_s [N],
 *                 no-load line speed v0 [m/s], reflected mass M [kg], viscous c [N s/m],
 *                 Coulomb F_c [N], position-loop time t_p [s], back-drivable (1) or not (0)]
 * The dynamics callback moves the rest length one motor step (its rate into act_dot) and keeps
 * the running peak; the bias callback returns -f, the tension from the rest length after that
 * step (exactly as MuJoCo's Euler step will integrate it: l + l_dot * dt).
 * Actuators without the marker go to the callback installed before tensim's, if any.
 * Every operation mirrors _laws.py in the same order, so the two agree to rounding.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>

#include <mujoco/mujoco.h>

#define TENSIM_CABLE_MARKER 7317.0 /* dynprm[0] of a tensim cable actuator */
#define MODE_IMPEDANCE 1.0

static mjfAct previous_dyn = NULL;
static mjfAct previous_bias = NULL;

int tensim_header_version(void) { return mjVERSION_HEADER; }

/* Sets the callbacks that actuators other than tensim's are handed to (NULL: none). */
void tensim_set_previous(mjfAct dyn, mjfAct bias) {
  previous_dyn = dyn;
  previous_bias = bias;
}

double tensim_marker(void) { return TENSIM_CABLE_MARKER; }

static int is_cable(const mjModel* m, int i) {
  int actnum = m->actuator_actnum[i];
  return m->actuator_dynprm[i * mjNDYN] == TENSIM_CABLE_MARKER && (actnum == 2 || actnum == 3);
}

/* DC motor (actdim 3): one step of the spool's line speed act[adr + 2] under its torque-speed
 * curve, inertia, friction and the cable's tension (_laws.dc_drive, _laws.dc_motor_speed);
 * writes the speed's rate and returns the new rest length. */
static double dc_step(const mjModel* m, const mjData* d, int i, const mjtNum* p,
                      const mjtNum* b, double target, double x, double v, double rest,
                      double dt) {
  int adr = m->actuator_actadr[i];
  double speed = d->act[adr + 2];
  double stretch = x - rest;
  double measured = stretch > 0.0 ? b[0] * stretch : 0.0;
  double applied = stretch > 0.0 ? fmax(measured + b[1] * v, 0.0) : 0.0;
  /* position loop: full voltage at an error of v0 t_p; no reeling in past the limits */
  double error = (target - rest) / (b[4] * b[8]);
  double drive = fmin(fmax(error, -1.0), 1.0);
  if (drive < 0.0 && (measured >= p[3] || x <= p[5])) drive = 0.0;
  /* backward Euler in the speed, Coulomb friction set-valued (the spool may stick) */
  double inertia = b[5] + dt * (b[3] / b[4] + b[6]);
  double free = (b[5] * speed + dt * (applied + b[3] * drive)) / inertia;
  double slip = dt * b[7] / inertia;
  double next_speed = fabs(free) > slip ? free - copysign(slip, free) : 0.0;
  if (b[9] == 0.0) { /* a worm gear: the spool turns only where the motor drives it */
    if (drive > 0.0) {
      next_speed = fmax(next_speed, 0.0);
    } else if (drive < 0.0) {
      next_speed = fmin(next_speed, 0.0);
    } else {
      next_speed = 0.0;
    }
  }
  double next = rest + next_speed * dt;
  if (next < p[4]) { /* the floor on the rest length stops the spool */
    next = p[4];
    next_speed = 0.0;
  }
  mjtNum* act_dot = (mjtNum*)d->act_dot;
  act_dot[adr + 2] = (next_speed - speed) / dt;
  return next;
}

/* The rest length after this step's motor update, as Euler integration will store it. */
static double next_rest(const mjModel* m, const mjData* d, int i) {
  int adr = m->actuator_actadr[i];
  return d->act[adr] + d->act_dot[adr] * m->opt.timestep;
}

mjtNum tensim_act_dyn(const mjModel* m, const mjData* d, int i) {
  if (!is_cable(m, i)) return previous_dyn ? previous_dyn(m, d, i) : 0.0;
  const mjtNum* p = m->actuator_dynprm + i * mjNDYN;
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  int tendon = m->actuator_trnid[2 * i];
  int adr = m->actuator_actadr[i];
  double dt = m->opt.timestep;
  double x = d->ten_length[tendon], v = d->ten_velocity[tendon];
  double k = b[0], rest = d->act[adr], input = d->ctrl[m->actuator_ctrladr[i]];
  double target;
  if (p[1] == MODE_IMPEDANCE) {
    /* impedance law (eq. 3): the rest length that turns the measured tension into T_set */
    double stretch = x - rest;
    double measured = stretch > 0.0 ? k * stretch : 0.0;
    double set = fmax(0.0, p[6] + p[7] * (x - p[9]) + p[8] * (v - input));
    target = rest - (set - measured) / k;
  } else {
    target = input;
  }
  double next;
  if (m->actuator_actnum[i] == 3) {
    next = dc_step(m, d, i, p, b, target, x, v, rest, dt);
  } else {
    /* motor: at most max_speed, never reeling in past max_tension or below the floors */
    double reach = p[2] * dt;
    double step = fmin(fmax(target - rest, -reach), reach);
    next = rest + step;
    if (step < 0.0) {
      double force_floor = fmin(rest, x - p[3] / k);
      next = fmax(next, force_floor);
      if (x <= p[5]) next = rest;
    }
    next = fmax(next, p[4]);
  }
  mjtNum* act_dot = (mjtNum*)d->act_dot; /* multi-activation user dynamics write act_dot */
  act_dot[adr] = (next - rest) / dt;
  /* peak: the running maximum of the load-cell tension k max(0, x - l) */
  double stretch = x - (rest + act_dot[adr] * dt);
  double spring = stretch > 0.0 ? k * stretch : 0.0;
  double peak = d->act[adr + 1];
  act_dot[adr + 1] = (fmax(peak, spring) - peak) / dt;
  return act_dot[adr + 1];
}

mjtNum tensim_act_bias(const mjModel* m, const mjData* d, int i) {
  if (!is_cable(m, i)) return previous_bias ? previous_bias(m, d, i) : 0.0;
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  int tendon = m->actuator_trnid[2 * i];
  /* cable (eq. 1-2): tension-only Hooke spring with linear damping, pulling the anchors in */
  double stretch = d->ten_length[tendon] - next_rest(m, d, i);
  if (stretch <= 0.0) return 0.0;
  double spring = b[0] * stretch;
  return -fmax(spring + b[1] * d->ten_velocity[tendon], 0.0);
}

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cable",
                             "Compiled tensim cable law (loaded through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__cable(void) { return PyModule_Create(&module); }
