/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: smoothed Mindlin contact law in 3D, LAMMPS-free kernel.

   The law of mindlin_smooth_kernel.h (Hertz normal force, smoothed
   Mindlin tangential force of Eq. (3)) for spheres, with the tangential
   displacement a vector t in the tangent plane of the contact.

   Geometry.  For spheres i, j with r = x_i - x_j, n = r/|r| and overlap
   delta = R_i + R_j - |r| (a wall: n = the wall's normal into the sphere):

     slip velocity     w = (v_i - v_j) - (R_i om_i + R_j om_j) x n,
                       slip = w - (w.n) n          (contact point of i
                       relative to j, tangential part; R_j om_j = 0, v_j = 0
                       for a wall)
     history rule      t <- |t| P t / |P t|,  P = 1 - n n^T  (projected onto
                       the current tangent plane, length kept; 0 if P t = 0),
                       then t <- t + dt slip  (advancing steps only)
     t*                mu k_n delta / k_t
     Coulomb sliding   |t| > t*  =>  t <- (t* / |t|) t   (direction kept)
     normal force      F_n = k_n delta^{3/2} n
     tangential force  F_t = -k_t delta^{1/2} g(u) t,  u = |t|/t*
     torque on i       T_i = (-R_i n) x F_t          (lever arm R_i)
     sphere j          n, t, slip and F change sign, T_j = (-R_j n) x F_t

   The projection rule is that of LAMMPS `tangential mindlin` (Luding,
   Granular Matter 10, 235 (2008), Eq. 17), applied whenever t.n != 0
   (LAMMPS skips it below a small threshold).  For motion in the xy plane
   (n and t in the plane, om along z) it gives t = xi s with s = (n_y, -n_x)
   and d xi = s.(dr_i - dr_j) + R_i dth_i + R_j dth_j: the 2D law of
   mindlin_smooth_kernel.h, to round-off.

   Mirror symmetry: the operations for sphere j are those for i with n,
   v_i - v_j and t negated, which floating point reproduces exactly, so the
   two sides keep t_ji = -t_ij and F_j = -F_i bitwise.
------------------------------------------------------------------------- */

#ifndef REMOTE_TRIGGER_MINDLIN_SMOOTH_KERNEL_3D_H
#define REMOTE_TRIGGER_MINDLIN_SMOOTH_KERNEL_3D_H

#include "mindlin_smooth_kernel.h"

#include <cmath>

namespace MindlinSmooth {

// Response of one 3D contact after the Coulomb cap.
struct Response3 {
  double t[3];    // tangential displacement after the cap (length)
  double fn;      // normal force magnitude k_n delta^{3/2} (force, >= 0)
  double ft[3];   // tangential force on sphere i (force)
  double u;       // |t|/t*; 0 if t* = 0
  int sliding;    // 1 if the cap was applied
};

inline double dot3(const double a[3], const double b[3])
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// c = a x b
inline void cross3(const double a[3], const double b[3], double c[3])
{
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

// History rule: t onto the tangent plane of the unit normal n, its length kept.
inline void project_keep_length(const double n[3], double t[3])
{
  const double tn = dot3(t, n);
  if (tn == 0.0) return;
  const double len2 = dot3(t, t);
  for (int a = 0; a < 3; a++) t[a] -= tn * n[a];
  const double plen2 = dot3(t, t);
  const double scale = (plen2 > 0.0) ? std::sqrt(len2 / plen2) : 0.0;
  for (int a = 0; a < 3; a++) t[a] *= scale;
}

// Tangential slip velocity of the contact point of i relative to j:
// dv = v_i - v_j, w = R_i om_i + R_j om_j.
inline void slip3(const double n[3], const double dv[3], const double w[3], double slip[3])
{
  double wxn[3];
  cross3(w, n, wxn);
  double rel[3];
  for (int a = 0; a < 3; a++) rel[a] = dv[a] - wxn[a];
  const double rn = dot3(rel, n);
  for (int a = 0; a < 3; a++) slip[a] = rel[a] - rn * n[a];
}

// Contact response for overlap delta > 0 and trial tangential displacement
// t_trial (in the tangent plane): the law with its Coulomb cap.
inline Response3 evaluate3(const Params &p, double delta, const double t_trial[3])
{
  Response3 r;
  const double sqd = std::sqrt(delta);
  r.fn = p.kn * delta * sqd;
  r.sliding = 0;
  const double ts = tstar(p, delta);
  const double len = std::sqrt(dot3(t_trial, t_trial));
  if (p.kt == 0.0 || !(ts > 0.0)) {
    // no tangential force (mu = 0, k_t = 0, or t* underflowed); history kept at zero
    r.sliding = (p.kt != 0.0 && len != 0.0) ? 1 : 0;
    for (int a = 0; a < 3; a++) r.t[a] = r.ft[a] = 0.0;
    r.u = 0.0;
    return r;
  }
  double scale = 1.0;
  r.u = len / ts;
  if (len > ts) {
    scale = ts / len;
    r.u = 1.0;
    r.sliding = 1;
  }
  const double c = -p.kt * sqd * gfun(r.u);
  for (int a = 0; a < 3; a++) {
    r.t[a] = (r.sliding) ? t_trial[a] * scale : t_trial[a];
    r.ft[a] = c * r.t[a];
  }
  return r;
}

// One step of one contact, the same for sphere-sphere and sphere-wall: the
// stored t is projected onto the current tangent plane; during an MD step
// (advance) it then grows by dt slip; then the law with its Coulomb cap.
// Setup (advance = false) only evaluates; the caller stores r.t only when
// advancing.
inline Response3 step3(const Params &p, double delta, const double n[3], const double stored[3],
                       const double slip[3], double dt, bool advance)
{
  double t[3] = {stored[0], stored[1], stored[2]};
  project_keep_length(n, t);
  if (advance)
    for (int a = 0; a < 3; a++) t[a] += dt * slip[a];
  return evaluate3(p, delta, t);
}

// Torque on sphere i (lever arm R_i, contact point x_i - R_i n):
// T = (-R_i n) x F_t.
inline void torque3(double radius, const double n[3], const double ft[3], double tq[3])
{
  double nxf[3];
  cross3(n, ft, nxf);
  for (int a = 0; a < 3; a++) tq[a] = -radius * nxf[a];
}

// Force and torque on sphere i from a sphere-sphere contact, for tests:
// d = x_i - x_j (not zero), stored history t (projected here, not advanced).
// out[0..2] = F, out[3..5] = T_i.  Returns the response; delta <= 0: zero.
inline Response3 pair_force3(const Params &p, const double d[3], double ri, double rj,
                             const double t[3], double out[6])
{
  Response3 res = {{0.0, 0.0, 0.0}, 0.0, {0.0, 0.0, 0.0}, 0.0, 0};
  for (int a = 0; a < 6; a++) out[a] = 0.0;
  const double r = std::sqrt(dot3(d, d));
  const double delta = ri + rj - r;
  if (delta <= 0.0) return res;
  const double n[3] = {d[0] / r, d[1] / r, d[2] / r};
  const double zero[3] = {0.0, 0.0, 0.0};
  res = step3(p, delta, n, t, zero, 0.0, false);
  for (int a = 0; a < 3; a++) out[a] = res.fn * n[a] + res.ft[a];
  torque3(ri, n, res.ft, out + 3);
  return res;
}

}    // namespace MindlinSmooth

#endif
