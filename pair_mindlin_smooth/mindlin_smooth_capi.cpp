/* ----------------------------------------------------------------------
   remote-trigger: C entry points to the contact-law kernel, so that the
   exact code the pair style runs can be called from Python (ctypes) for
   tests and cross-checks.  No LAMMPS dependency.
------------------------------------------------------------------------- */

#include "mindlin_smooth_kernel.h"
#include "mindlin_smooth_kernel_3d.h"

using namespace MindlinSmooth;

extern "C" {

// out = (xi, fn, ft, u, sliding)
void ms_evaluate(double kn, double kt, double mu, double delta, double xi_trial, double *out)
{
  const Params p = {kn, kt, mu};
  const Response r = evaluate(p, delta, xi_trial);
  out[0] = r.xi;
  out[1] = r.fn;
  out[2] = r.ft;
  out[3] = r.u;
  out[4] = r.sliding;
}

// out = (dfn/ddelta, dft/ddelta, dft/dxi)
void ms_derivatives(double kn, double kt, double mu, double delta, double xi_trial, double *out)
{
  const Params p = {kn, kt, mu};
  const Derivs d = derivatives(p, delta, xi_trial);
  out[0] = d.dfn_ddelta;
  out[1] = d.dft_ddelta;
  out[2] = d.dft_dxi;
}

// out = (F_x, F_y, T_i/R_i) on disk i
void ms_pair_force(double kn, double kt, double mu, double dx, double dy, double ri, double rj,
                   double xi, double *out)
{
  const Params p = {kn, kt, mu};
  pair_force(p, dx, dy, ri, rj, xi, out);
}

// K: 3 x 6 row-major
void ms_pair_stiffness(double kn, double kt, double mu, double dx, double dy, double ri,
                       double rj, double xi, double *K)
{
  const Params p = {kn, kt, mu};
  pair_stiffness(p, dx, dy, ri, rj, xi, K);
}

// out = (F_x, F_y, T/R)
void ms_wall_force(double kn, double kt, double mu, double delta, double xi, double *out)
{
  const Params p = {kn, kt, mu};
  wall_force(p, delta, xi, out);
}

// K: 3 x 3 row-major
void ms_wall_stiffness(double kn, double kt, double mu, double delta, double xi, double *K)
{
  const Params p = {kn, kt, mu};
  wall_stiffness(p, delta, xi, K);
}

// 3D: out = (t[3], fn, ft[3], u, sliding) after the cap, for trial t
void ms_evaluate3(double kn, double kt, double mu, double delta, double t0, double t1,
                  double t2, double *out)
{
  const Params p = {kn, kt, mu};
  const double t[3] = {t0, t1, t2};
  const Response3 r = evaluate3(p, delta, t);
  for (int a = 0; a < 3; a++) {
    out[a] = r.t[a];
    out[4 + a] = r.ft[a];
  }
  out[3] = r.fn;
  out[7] = r.u;
  out[8] = r.sliding;
}

// 3D step: stored t projected onto the plane of the unit normal n, advanced
// by dt slip (slip = tangential slip velocity from dv = v_i - v_j and
// w = R_i om_i + R_j om_j), capped.  out = as ms_evaluate3, then slip[3].
void ms_step3(double kn, double kt, double mu, double delta, const double *n,
              const double *stored, const double *dv, const double *w, double dt, double *out)
{
  const Params p = {kn, kt, mu};
  double slip[3];
  slip3(n, dv, w, slip);
  const Response3 r = step3(p, delta, n, stored, slip, dt, true);
  for (int a = 0; a < 3; a++) {
    out[a] = r.t[a];
    out[4 + a] = r.ft[a];
    out[9 + a] = slip[a];
  }
  out[3] = r.fn;
  out[7] = r.u;
  out[8] = r.sliding;
}

// 3D: out = (F[3], T_i[3]) on sphere i, d = x_i - x_j, stored t
void ms_pair_force3(double kn, double kt, double mu, const double *d, double ri, double rj,
                    const double *t, double *out)
{
  const Params p = {kn, kt, mu};
  pair_force3(p, d, ri, rj, t, out);
}
}
