/* Compiled observation of many robots: the rolling observation's terms, written straight from
 * the batch engine's fields into each robot's row.
 *
 * tensim/rl/_worlds.py computes the same observation with NumPy (its reference); every
 * operation here mirrors it in the same order (the same sums, products and square roots, no
 * fused multiply-add), so the two agree to the bit. Terms (each one's first column in a row,
 * or -1 where the observation lacks it):
 *   height           the centre of mass's height [m]
 *   velocity         the centre of mass's linear velocity, then each rigid body's linear
 *                    velocity and angular velocity, in the observation frame
 *   rod_axis         each rod's unit vector from its first end to its second, in the frame
 *   cable_length     each cable's length [m]
 *   contact          1 where a rigid body touches the ground (its contact sensor found any)
 *   end_contact      1 at the rod end nearest each ground contact of its body
 *   task             the heading (direction task) or the goal from the centre of mass (goal
 *                    task), in the frame; 0 for other tasks
 *   previous_action  the last action applied
 *   position         the centre of mass's (x, y) in the world [m]
 * The frame turns world vectors by the yaw whose cosine and sine are given per robot.
 * Nothing is kept between calls.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <string.h>

/* Field views of the batch engine and the environment's arrays (row strides in doubles), the
 * robot's indices and the observation's columns. Mirrored by _observe_native.Spec. */
typedef struct {
  const double *subtree_com, *xipos, *xpos, *xmat, *cvel, *ten_length, *sensordata;
  long long subtree_com_stride, xipos_stride, xpos_stride, xmat_stride, cvel_stride,
      ten_length_stride, sensordata_stride;
  const double *target;   /* (n, 2) unit heading or goal position [m] */
  const double *previous; /* (n, n_motors) */
  int n_bodies;           /* rigid bodies */
  const int *body;        /* (n_bodies,) their MuJoCo body ids */
  const int *root;        /* (n_bodies,) the ids of their root bodies */
  const double *mass;     /* (n_bodies,) mass fractions */
  int n_ends;             /* rod ends, 2 per rod */
  const int *end_body;    /* (n_ends,) MuJoCo body id of each end */
  const double *end_local;/* (n_ends, 3) each end in its body's frame [m] */
  int n_cables;
  const int *tendon;      /* (n_cables,) tendon ids */
  int n_motors;
  const int *sensor_adr;  /* (n_bodies,) each body's ground contact sensor in sensordata */
  int slots;              /* contacts a sensor holds, 4 values (found, x, y, z) each */
  int most;               /* most rod ends on one body */
  const int *body_ends;   /* (n_bodies, most) each body's ends in order, -1 padding */
  int task;               /* 0: none, 1: direction, 2: goal */
  int height, velocity, rod_axis, cable_length, contact, end_contact, task_column,
      previous_action, position, size;
} Spec;

/* what the loader checks: a build of other sources (another version) is not used */
#define TENSIM_OBSERVE_VERSION 1
int tensim_observe_version(void) { return TENSIM_OBSERVE_VERSION; }
int tensim_observe_spec_size(void) { return (int)sizeof(Spec); }

/* turns the world vector v (x, y, z) about z into the frame: x' = c x + s y, y' = -s x + c y */
static void turn(double *v, double c, double s) {
  double x = v[0], y = v[1];
  v[0] = c * x + s * y;
  v[1] = -s * x + c * y;
}

/* the rod ends' world positions (n_ends, 3): the body's position plus its xmat times the
 * local offset. Each row's three products are summed as NumPy's einsum sums them (in SIMD
 * lanes of two or more, the lanes then added: the first and third, then the second). */
static void end_positions(const Spec *p, int i, double *ends) {
  const double *xpos = p->xpos + i * p->xpos_stride, *xmat = p->xmat + i * p->xmat_stride;
  for (int e = 0; e < p->n_ends; e++) {
    const double *pos = xpos + 3 * p->end_body[e], *mat = xmat + 9 * p->end_body[e];
    const double *local = p->end_local + 3 * e;
    for (int x = 0; x < 3; x++) {
      double sum = mat[3 * x] * local[0] + mat[3 * x + 2] * local[2];
      sum += mat[3 * x + 1] * local[1];
      ends[3 * e + x] = pos[x] + sum;
    }
  }
}

static void velocity(const Spec *p, int i, double c, double s, double *row) {
  const double *cvel = p->cvel + i * p->cvel_stride, *xipos = p->xipos + i * p->xipos_stride;
  const double *com = p->subtree_com + i * p->subtree_com_stride;
  int nb = p->n_bodies;
  double *centre = row, *linear = row + 3, *angular = row + 3 + 3 * nb;
  for (int b = 0; b < nb; b++) {
    /* cvel: (rotation, translation) at the root's centre of mass; the body's own centre
     * moves with the translation plus rotation x (xipos - root com) */
    const double *v = cvel + 6 * p->body[b], *at = xipos + 3 * p->body[b];
    const double *origin = com + 3 * p->root[b];
    double r[3] = {at[0] - origin[0], at[1] - origin[1], at[2] - origin[2]};
    double *out = linear + 3 * b;
    out[0] = v[3] + (v[1] * r[2] - v[2] * r[1]);
    out[1] = v[4] + (v[2] * r[0] - v[0] * r[2]);
    out[2] = v[5] + (v[0] * r[1] - v[1] * r[0]);
    angular[3 * b] = v[0];
    angular[3 * b + 1] = v[1];
    angular[3 * b + 2] = v[2];
  }
  for (int x = 0; x < 3; x++) { /* the mass-weighted mean, summed body by body */
    double sum = 0.0;
    for (int b = 0; b < nb; b++) sum += p->mass[b] * linear[3 * b + x];
    centre[x] = sum;
  }
  for (int j = 0; j < 1 + 2 * nb; j++) turn(row + 3 * j, c, s);
}

static void rod_axes(const Spec *p, const double *ends, double c, double s, double *row) {
  for (int rod = 0; rod < p->n_ends / 2; rod++) {
    const double *first = ends + 6 * rod, *second = first + 3;
    double a[3] = {second[0] - first[0], second[1] - first[1], second[2] - first[2]};
    double norm = a[0] * a[0];
    norm += a[1] * a[1];
    norm += a[2] * a[2];
    norm = sqrt(norm);
    double *out = row + 3 * rod;
    out[0] = a[0] / norm;
    out[1] = a[1] / norm;
    out[2] = a[2] / norm;
    turn(out, c, s);
  }
}

/* ground contacts from the sensors; returns 1 where a body has more contacts than its
 * sensor holds (the caller reads that robot's contacts from its contact list instead) */
static int contacts(const Spec *p, int i, const double *ends, double *touch, double *at_end) {
  const double *data = p->sensordata + i * p->sensordata_stride;
  int over = 0;
  if (at_end)
    for (int e = 0; e < p->n_ends; e++) at_end[e] = 0.0;
  for (int b = 0; b < p->n_bodies; b++) {
    const double *sensor = data + p->sensor_adr[b];
    double found = sensor[0];
    if (touch) touch[b] = found > 0 ? 1.0 : 0.0;
    if (found > p->slots) over = 1;
    if (!at_end || !ends) continue;
    const int *own = p->body_ends + b * p->most;
    for (int k = 0; k < p->slots; k++) {
      const double *slot = sensor + 4 * k;
      if (slot[0] == 0) continue;
      int nearest = -1;
      double least = INFINITY;
      for (int j = 0; j < p->most && own[j] >= 0; j++) { /* the first of equals */
        const double *end = ends + 3 * own[j];
        double g[3] = {end[0] - slot[1], end[1] - slot[2], end[2] - slot[3]};
        double far = g[0] * g[0];
        far += g[1] * g[1];
        far += g[2] * g[2];
        far = sqrt(far);
        if (nearest < 0 || far < least) {
          nearest = j;
          least = far;
        }
      }
      if (nearest >= 0 && least < INFINITY) at_end[own[nearest]] = 1.0;
    }
  }
  return over;
}

/* Writes the observations of robots ids[0..k) into out (k, size); over[j] = 1 where robot
 * ids[j]'s contact flags must come from its contact list, and returns how many those are.
 * cosine, sine: (k,) the frames. */
int tensim_observe(const Spec *p, int k, const int *ids, const double *cosine,
                   const double *sine, double *out, unsigned char *over) {
  double ends[3 * 256];
  int overs = 0;
  for (int j = 0; j < k; j++) {
    int i = ids[j];
    double c = cosine[j], s = sine[j], *row = out + (long long)j * p->size;
    const double *com = p->subtree_com + i * p->subtree_com_stride;
    if (p->height >= 0) row[p->height] = com[2];
    if (p->velocity >= 0) velocity(p, i, c, s, row + p->velocity);
    int need_ends = p->n_ends > 0 && (p->rod_axis >= 0 || p->end_contact >= 0);
    if (need_ends) end_positions(p, i, ends);
    if (p->rod_axis >= 0) rod_axes(p, ends, c, s, row + p->rod_axis);
    if (p->cable_length >= 0) {
      const double *length = p->ten_length + i * p->ten_length_stride;
      for (int m = 0; m < p->n_cables; m++) row[p->cable_length + m] = length[p->tendon[m]];
    }
    over[j] = 0;
    if (p->contact >= 0 || p->end_contact >= 0)
      over[j] = (unsigned char)contacts(
          p, i, need_ends ? ends : NULL, p->contact >= 0 ? row + p->contact : NULL,
          p->end_contact >= 0 ? row + p->end_contact : NULL);
    overs += over[j];
    if (p->task_column >= 0) {
      double v[3] = {0.0, 0.0, 0.0};
      const double *target = p->target + 2 * i;
      if (p->task == 1) {
        v[0] = target[0];
        v[1] = target[1];
      } else if (p->task == 2) {
        v[0] = target[0] - com[0];
        v[1] = target[1] - com[1];
      }
      if (p->task) turn(v, c, s);
      row[p->task_column] = v[0];
      row[p->task_column + 1] = v[1];
    }
    if (p->previous_action >= 0)
      memcpy(row + p->previous_action, p->previous + (long long)i * p->n_motors,
             sizeof(double) * p->n_motors);
    if (p->position >= 0) {
      row[p->position] = com[0];
      row[p->position + 1] = com[1];
    }
  }
  return overs;
}

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "_observe",
                             "Compiled tensim RL observation (loaded through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__observe(void) { return PyModule_Create(&module); }
