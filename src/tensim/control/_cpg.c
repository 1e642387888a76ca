/* Compiled CPG integrator: eq. 4-5 of cpg.py solved by scipy's DOP853, step for step.
 *
 * The state is y = [θ (n), r (n), dr/dt (n)]. Every stage of the method follows
 * scipy.integrate.solve_ivp(method="DOP853", t_eval=...) as scipy 1.17 writes it: the
 * same initial step choice (Hairer, Nørsett and Wanner, sec. II.4), the same embedded 5th/3rd
 * order error norm and step-size factors (safety 0.9, between 0.2 and 10), the same 7th-order
 * dense output at the sample times, the same guards. So it takes scipy's steps up to rounding
 * (the order of sums, and the coupling's sine, which is taken from the oscillators' sin θ and
 * cos θ rather than per coupling); rounding in the error estimate can flip the odd
 * accept/reject decision, after which the two agree within the method's own error.
 * The tableau is Hairer's dop853.f (Dormand and Prince's 8(5,3) pair), as scipy holds it.
 * Nothing is kept between calls, so calls from many threads at once are safe.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* status codes, read by _cpg_native.py */
#define OK 0
#define AMPLITUDE 1   /* |r| reached its bound (the time is returned) */
#define EVALUATIONS 2 /* more than max_evaluations right-hand side evaluations */
#define WALL_TIME 3   /* more than max_wall_s of wall time */
#define STEP_TOO_SMALL 4
#define NO_MEMORY 5

#define STAGES 12
#define STAGES_EXTENDED 16
#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
#define ERROR_EXPONENT (-1.0 / 8.0) /* -1 / (error estimator order 7 + 1) */

/* Runge-Kutta matrix: rows 1-11 the method's stages, row 12 the solution weights (B), rows
 * 13-15 the extra stages of the dense output. */
static const double A[STAGES_EXTENDED][STAGES_EXTENDED] = {
    {0.0},
    {0.05260015195876773},
    {0.0197250569845379, 0.0591751709536137},
    {0.02958758547680685, 0.0, 0.08876275643042054},
    {0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792},
    {0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242},
    {0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125},
    {0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328,
     -0.015319437748624402, 0.008273789163814023},
    {0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671,
     20.154067550477894, -43.48988418106996},
    {0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843,
     21.230051448181193, 15.279233632882423, -33.28821096898486, -0.020331201708508627},
    {-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927,
     -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196},
    {2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188,
     27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303,
     0.6433927460157636},
    {0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
     -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034,
     0.04471061572777259},
    {0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025,
     -0.12419142326381637, 0.15329179827876568, 0.00820105229563469, 0.007567897660545699,
     -0.008298},
    {0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566,
     -0.05492374857139099, 0.0, 0.0, -0.00010834732869724932, 0.0003825710908356584,
     -0.00034046500868740456, 0.1413124436746325},
    {-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599,
     4.06898981839711, 0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145,
     2.9475147891527724, -9.15095847217987},
};
static const double C[STAGES_EXTENDED] = {
    0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
    0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571,
    1.0, 1.0, 0.1, 0.2, 0.7777777777777778};
/* error estimators of 5th and 3rd order (over the 12 stages; the 13th, f_new, has weight 0) */
static const double E5[STAGES] = {
    0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502,
    1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571,
    -0.022355307863886294};
static const double E3[STAGES] = {
    -0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
    -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034,
    0.02265179219836082};
/* dense output: the 4 higher coefficients of the 7th-degree interpolant */
static const double D[4][STAGES_EXTENDED] = {
    {-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917,
     2.38466765651207, 2.117034582445028, -0.871391583777973, 2.2404374302607883,
     0.6315787787694688, -0.08899033645133331, 18.148505520854727, -9.194632392478356,
     -4.436036387594894},
    {10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028,
     -374.5467547226902, -22.113666853125306, 7.733432668472264, -30.674084731089398,
     -9.332130526430229, 15.697238121770845, -31.139403219565178, -9.35292435884448,
     35.81684148639408},
    {19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758,
     527.8081592054236, -11.57390253995963, 6.8812326946963, -1.0006050966910838,
     0.7777137798053443, -2.778205752353508, -60.19669523126412, 84.32040550667716,
     11.99229113618279},
    {-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455,
     357.6391179106141, 93.40532418362432, -37.45832313645163, 104.0996495089623,
     29.8402934266605, -43.53345659001114, 96.32455395918828, -39.17726167561544,
     -149.72683625798564},
};

/* The network and the right-hand side's bookkeeping (evaluation count, wall clock). */
typedef struct {
  int n, m;                         /* oscillators, couplings */
  const double *omega, *target, *a; /* 2πν [rad/s], R [m/s], a [1/s], each (n,) */
  const int *ci, *cj;               /* coupling i <- j, each (m,) */
  const double *wcos, *wsin;        /* w cos φ, w sin φ [rad/m], each (m,) */
  double *sin_theta, *cos_theta, *drive; /* scratch, each (n,) */
  long long evaluations, max_evaluations;
  double max_wall_s;
  struct timespec start;
} Network;

static double elapsed_s(const struct timespec* start) {
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return (double)(now.tv_sec - start->tv_sec) + 1e-9 * (double)(now.tv_nsec - start->tv_nsec);
}

/* f = dy/dt (eq. 4-5); a nonzero return is a guard's status. */
static int rhs(Network* net, const double* y, double* f) {
  int n = net->n;
  net->evaluations += 1;
  if (net->evaluations > net->max_evaluations) return EVALUATIONS;
  if (net->evaluations % 64 == 1 && elapsed_s(&net->start) > net->max_wall_s) return WALL_TIME;
  const double *theta = y, *r = y + n, *dr = y + 2 * n;
  for (int i = 0; i < n; ++i) {
    net->sin_theta[i] = sin(theta[i]);
    net->cos_theta[i] = cos(theta[i]);
    net->drive[i] = 0.0;
  }
  /* coupling (eq. 4): r_j w_ij sin(θ_j − θ_i − φ_ij), the sine of the difference expanded */
  for (int k = 0; k < net->m; ++k) {
    int i = net->ci[k], j = net->cj[k];
    double s = net->sin_theta[j] * net->cos_theta[i] - net->cos_theta[j] * net->sin_theta[i];
    double c = net->cos_theta[j] * net->cos_theta[i] + net->sin_theta[j] * net->sin_theta[i];
    net->drive[i] += r[j] * (net->wcos[k] * s - net->wsin[k] * c);
  }
  for (int i = 0; i < n; ++i) {
    f[i] = net->omega[i] + net->drive[i];
    f[n + i] = dr[i];
    /* amplitude (eq. 5): critically damped approach to R */
    f[2 * n + i] = net->a[i] * (net->a[i] / 4 * (net->target[i] - r[i]) - dr[i]);
  }
  return OK;
}

static double rms(const double* x, const double* scale, int size) {
  double sum = 0.0;
  for (int i = 0; i < size; ++i) sum += (x[i] / scale[i]) * (x[i] / scale[i]);
  return sqrt(sum) / sqrt((double)size);
}

/* sum = Σ_k a[k] K[k] over the first s stages, summed in stage order (zero weights skipped) */
static void weighted_sum(const double* K, const double* a, int s, int size, double* sum) {
  for (int i = 0; i < size; ++i) sum[i] = 0.0;
  for (int k = 0; k < s; ++k) {
    if (a[k] == 0.0) continue;
    const double* row = K + k * size;
    for (int i = 0; i < size; ++i) sum[i] += row[i] * a[k];
  }
}

/* out = y + h Σ_k a[k] K[k] over the first s stages */
static void combine(const double* y, const double* K, const double* a, int s, double h,
                    int size, double* out) {
  weighted_sum(K, a, s, size, out);
  for (int i = 0; i < size; ++i) out[i] = y[i] + out[i] * h;
}

/* Writes θ and r at the sample times in (t_old, t] from the dense output of the last step. */
static int samples(Network* net, double* K, const double* y_old, const double* y,
                   const double* f_new, double t_old, double t, double h, int size,
                   const double* times, int n_times, int* next, double* out, double* F,
                   double* tmp) {
  for (int s = STAGES + 1; s < STAGES_EXTENDED; ++s) {
    combine(y_old, K, A[s], s, h, size, tmp);
    int status = rhs(net, tmp, K + s * size);
    if (status) return status;
  }
  for (int i = 0; i < size; ++i) {
    double delta = y[i] - y_old[i], f_old = K[i];
    F[i] = delta;
    F[size + i] = h * f_old - delta;
    F[2 * size + i] = 2 * delta - h * (f_new[i] + f_old);
  }
  for (int q = 0; q < 4; ++q) {
    double* row = F + (3 + q) * size;
    weighted_sum(K, D[q], STAGES_EXTENDED, size, row);
    for (int i = 0; i < size; ++i) row[i] *= h;
  }
  double span = t - t_old;
  int n = net->n;
  for (; *next < n_times && times[*next] <= t; ++*next) {
    double x = (times[*next] - t_old) / span;
    for (int i = 0; i < 2 * n; ++i) { /* θ and r: the first 2n components */
      double v = 0.0;
      for (int q = 6; q >= 0; --q) {
        v += F[q * size + i];
        v *= ((6 - q) % 2 == 0) ? x : 1 - x;
      }
      out[(size_t)*next * 2 * n + i] = v + y_old[i];
    }
  }
  return OK;
}

static double initial_step(Network* net, const double* y0, const double* f0, double t_bound,
                           double rtol, double atol, int size, double* scale, double* y1,
                           double* f1, int* status) {
  for (int i = 0; i < size; ++i) scale[i] = atol + fabs(y0[i]) * rtol;
  double d0 = rms(y0, scale, size), d1 = rms(f0, scale, size);
  double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  h0 = fmin(h0, t_bound);
  for (int i = 0; i < size; ++i) y1[i] = y0[i] + h0 * f0[i];
  *status = rhs(net, y1, f1);
  if (*status) return 0.0;
  for (int i = 0; i < size; ++i) y1[i] = f1[i] - f0[i];
  double d2 = rms(y1, scale, size) / h0;
  double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3)
                                           : pow(0.01 / fmax(d1, d2), 1.0 / 8.0);
  return fmin(fmin(100 * h0, h1), t_bound);
}

static double max_abs(const double* x, int n) {
  double m = 0.0;
  for (int i = 0; i < n; ++i) m = fmax(m, fabs(x[i]));
  return m;
}

/* Integrates eq. 4-5 from t = 0 to t_bound and samples θ and r at `times` (ascending, within
 * [0, t_bound]) into out (n_times, 2n). Stops when max|r| reaches `bound`. info[0]: the time
 * integration stopped at, info[1]: right-hand side evaluations. Returns a status code. */
int tensim_cpg_dop853(int n, int m, const double* omega, const double* target, const double* a,
                      const int* ci, const int* cj, const double* wcos, const double* wsin,
                      const double* y0, double t_bound, int n_times, const double* times,
                      double rtol, double atol, double bound, long long max_evaluations,
                      double max_wall_s, double* out, double* info) {
  int size = 3 * n, status = OK, next = 0;
  /* K (16 rows), F (7 rows), y, y_new, f, scale, tmp, and the network's 3 scratch rows */
  double* block = malloc(sizeof(double) * (size_t)(size * (STAGES_EXTENDED + 7 + 5) + 3 * n));
  if (block == NULL) return NO_MEMORY;
  double *K = block, *F = K + STAGES_EXTENDED * size, *y = F + 7 * size, *y_new = y + size;
  double *f = y_new + size, *scale = f + size, *tmp = scale + size;
  Network net = {n, m, omega, target, a, ci, cj, wcos, wsin, tmp + size, tmp + size + n,
                 tmp + size + 2 * n, 0, max_evaluations, max_wall_s, {0, 0}};
  clock_gettime(CLOCK_MONOTONIC, &net.start);
  double t = 0.0, h_abs;
  memcpy(y, y0, sizeof(double) * size);
  status = rhs(&net, y, f);
  if (!status) h_abs = initial_step(&net, y, f, t_bound, rtol, atol, size, scale, y_new, tmp,
                                    &status);
  double g = bound - max_abs(y + n, n);
  while (!status && t != t_bound) {
    /* one accepted step: shrink until the error norm is below 1 */
    double min_step = 10 * fabs(nextafter(t, INFINITY) - t), t_new = t, h = 0.0;
    if (h_abs < min_step) h_abs = min_step;
    int accepted = 0, rejected = 0;
    while (!accepted) {
      if (h_abs < min_step) {
        status = STEP_TOO_SMALL;
        break;
      }
      t_new = t + h_abs;
      if (t_new - t_bound > 0) t_new = t_bound;
      h = t_new - t;
      h_abs = fabs(h);
      memcpy(K, f, sizeof(double) * size);
      for (int s = 1; s < STAGES && !status; ++s) {
        combine(y, K, A[s], s, h, size, tmp);
        status = rhs(&net, tmp, K + s * size);
      }
      if (status) break;
      combine(y, K, A[STAGES], STAGES, h, size, y_new); /* row 12 of A: the weights B */
      status = rhs(&net, y_new, K + STAGES * size);     /* f_new, the 13th row */
      if (status) break;
      double sum5 = 0.0, sum3 = 0.0, *e5 = tmp, *e3 = F; /* F is free until the samples */
      weighted_sum(K, E5, STAGES, size, e5);
      weighted_sum(K, E3, STAGES, size, e3);
      for (int i = 0; i < size; ++i) {
        double sc = atol + fmax(fabs(y[i]), fabs(y_new[i])) * rtol;
        sum5 += (e5[i] / sc) * (e5[i] / sc);
        sum3 += (e3[i] / sc) * (e3[i] / sc);
      }
      double error = (sum5 == 0.0 && sum3 == 0.0)
                         ? 0.0
                         : fabs(h) * sum5 / sqrt((sum5 + 0.01 * sum3) * size);
      if (error < 1) {
        double factor = error == 0.0 ? MAX_FACTOR
                                     : fmin(MAX_FACTOR, SAFETY * pow(error, ERROR_EXPONENT));
        if (rejected) factor = fmin(1.0, factor);
        h_abs *= factor;
        accepted = 1;
      } else {
        h_abs *= fmax(MIN_FACTOR, SAFETY * pow(error, ERROR_EXPONENT));
        rejected = 1;
      }
    }
    if (status) break;
    /* y_old, the step's start, goes to tmp for the dense output; f = f_new */
    double t_old = t;
    memcpy(scale, y, sizeof(double) * size);
    memcpy(y, y_new, sizeof(double) * size);
    memcpy(f, K + STAGES * size, sizeof(double) * size);
    t = t_new;
    /* the amplitude guard, as scipy's terminal event: max|r| crossing the bound */
    double g_new = bound - max_abs(y + n, n);
    if ((g <= 0 && g_new >= 0) || (g >= 0 && g_new <= 0)) {
      status = AMPLITUDE;
      break;
    }
    g = g_new;
    if (next < n_times && times[next] <= t)
      status = samples(&net, K, scale, y, f, t_old, t, h, size, times, n_times, &next, out, F,
                       tmp);
  }
  info[0] = t;
  info[1] = (double)net.evaluations;
  free(block);
  return status;
}

static PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cpg",
                             "Compiled tensim CPG integrator (loaded through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__cpg(void) { return PyModule_Create(&module); }
