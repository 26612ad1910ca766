/* ----------------------------------------------------------------------
   remote-trigger: C entry points to the contact-law kernel, so that the
   exact code the pair style runs can be called from Python (ctypes) for
   tests and cross-checks.  No LAMMPS dependency.
------------------------------------------------------------------------- */

#include "mindlin_smooth_kernel.h"

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
}
