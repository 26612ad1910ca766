/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: smoothed Mindlin contact law, LAMMPS-free kernel.

   Hertz normal force plus the smoothed Mindlin tangential force of
   Charan, Pomyalov & Procaccia, "Generic Mechanism for Remote Triggering
   of Earthquakes", Eqs. (1)-(3), (14) and Appendix C.

   Geometry (2D).  For disks i, j with r = x_i - x_j, n = r/|r|,
   overlap delta = R_i + R_j - |r| and tangent s = (n_y, -n_x):

     tangential displacement   t_ij = xi * s        (xi: signed scalar)
     history update            d xi = s.(dr_i - dr_j) + R_i dth_i + R_j dth_j
     normal force on i         F_n  = k_n delta^{3/2} n
     tangential force on i     F_t  = ft s,  ft = -k_t delta^{1/2} g(u) xi
                               g(u) = 1 + u - u^2,  u = |xi|/t*,
                               t*   = mu k_n delta / k_t
     torque on i               T_i  = R_i ft      (lever arm R_i)
     Coulomb sliding           |xi| > t*  =>  xi = sign(xi) t*

   In 2D the tangent plane is a line, so storing the scalar xi and
   rebuilding t = xi s from the current normal is exactly "rotate t with
   n, keeping its length".  For a flat wall below the disk, n = +y,
   s = +x and the same formulas hold with R_j -> infinity.

   Generalized coordinates per disk: (x, y, phi = R theta); generalized
   forces (F_x, F_y, T/R) (paper Eq. 42).  Stiffness K = -dF/dq.
------------------------------------------------------------------------- */

#ifndef REMOTE_TRIGGER_MINDLIN_SMOOTH_KERNEL_H
#define REMOTE_TRIGGER_MINDLIN_SMOOTH_KERNEL_H

#include <cmath>

namespace MindlinSmooth {

struct Params {
  double kn;    // normal stiffness, force/length^{3/2}
  double kt;    // tangential stiffness, force/length^{3/2}
  double mu;    // Coulomb friction coefficient (dimensionless)
};

// Response of one contact after the Coulomb cap.
struct Response {
  double xi;      // tangential displacement after the cap (length)
  double fn;      // normal force magnitude k_n delta^{3/2} (force, >= 0)
  double ft;      // tangential force along s on disk i (force)
  double u;       // |xi|/t*; 0 if t* = 0
  int sliding;    // 1 if the cap was applied
};

// Partial derivatives of the response, with xi following the cap.
struct Derivs {
  double dfn_ddelta;    // d fn / d delta
  double dft_ddelta;    // d ft / d delta at fixed trial xi
  double dft_dxi;       // d ft / d xi (zero at and beyond the Coulomb limit)
};

// Sliding length t* = mu k_n delta / k_t (Eq. 3).  Zero when mu = 0 (or
// when it underflows); +inf when k_t = 0 (no tangential force).
inline double tstar(const Params &p, double delta)
{
  if (p.kt == 0.0) return INFINITY;
  return p.mu * p.kn * delta / p.kt;
}

// Smoothing function g(u) = 1 + u - u^2 of Eq. (3).
inline double gfun(double u)
{
  return 1.0 + u - u * u;
}

// Contact response for overlap delta > 0 and trial tangential
// displacement xi_trial (stored value plus this step's increment).
inline Response evaluate(const Params &p, double delta, double xi_trial)
{
  Response r;
  const double sqd = std::sqrt(delta);
  r.fn = p.kn * delta * sqd;
  r.sliding = 0;
  const double ts = tstar(p, delta);
  if (p.kt == 0.0 || !(ts > 0.0)) {
    // no tangential force (mu = 0, k_t = 0, or t* underflowed to 0 for a
    // subnormal mu or delta); history is kept at zero
    r.sliding = (p.kt != 0.0 && xi_trial != 0.0) ? 1 : 0;
    r.xi = 0.0;
    r.ft = 0.0;
    r.u = 0.0;
    return r;
  }
  double xi = xi_trial;
  if (std::fabs(xi) > ts) {
    xi = std::copysign(ts, xi);
    r.sliding = 1;
  }
  const double u = std::fabs(xi) / ts;
  r.xi = xi;
  r.u = u;
  r.ft = -p.kt * sqd * gfun(u) * xi;
  return r;
}

// One step of one contact, the same for disk-disk and disk-wall: during
// an MD step (advance) the stored displacement xi grows by slip dt, with
// slip = s.(v_i - v_j) + R_i w_i + R_j w_j the velocity of the contact
// point of i relative to j along s (R_j w_j = 0 for a wall); then the law
// with its Coulomb cap.  Setup (advance = false) only evaluates.  The wall
// fix calls it; the pair's loop writes the same two operations out, with
// the slip computed only when advancing (8 % less pair time, measured).
inline Response step(const Params &p, double delta, double xi, double slip, double dt,
                     bool advance)
{
  if (advance) xi += dt * slip;
  return evaluate(p, delta, xi);
}

// Derivatives of fn and ft with respect to delta and xi.
// At u = 1 both branches (capped and free) give the same values:
// dft/dxi = 0 and dft/ddelta = -(3/2) sign(xi) mu k_n delta^{1/2}.
inline Derivs derivatives(const Params &p, double delta, double xi_trial)
{
  Derivs d;
  const double sqd = std::sqrt(delta);
  d.dfn_ddelta = 1.5 * p.kn * sqd;
  const double ts = tstar(p, delta);
  if (p.kt == 0.0 || !(ts > 0.0)) {
    d.dft_ddelta = 0.0;
    d.dft_dxi = 0.0;
    return d;
  }
  if (std::fabs(xi_trial) > ts) {
    // capped: ft = -sign(xi) mu k_n delta^{3/2}
    d.dft_ddelta = -std::copysign(1.5 * p.mu * p.kn * sqd, xi_trial);
    d.dft_dxi = 0.0;
    return d;
  }
  const double u = std::fabs(xi_trial) / ts;
  const double ft = -p.kt * sqd * gfun(u) * xi_trial;
  // du/ddelta = -u/delta because t* is proportional to delta
  d.dft_ddelta = 0.5 * ft / delta + p.kt * xi_trial * u * (1.0 - 2.0 * u) / sqd;
  d.dft_dxi = -p.kt * sqd * (1.0 + 2.0 * u - 3.0 * u * u);
  return d;
}

// Generalized force on disk i from a disk-disk contact:
// out[0..2] = (F_x, F_y, T_i/R_i).  dx, dy = x_i - x_j, not both zero
// (coincident centres have no normal; the LAMMPS styles reject them).
// Returns the response; delta <= 0 gives zero force.
inline Response pair_force(const Params &p, double dx, double dy, double ri, double rj,
                           double xi_trial, double out[3])
{
  const double r = std::sqrt(dx * dx + dy * dy);
  const double delta = ri + rj - r;
  Response res = {0.0, 0.0, 0.0, 0.0, 0};
  out[0] = out[1] = out[2] = 0.0;
  if (delta <= 0.0) return res;
  const double nx = dx / r, ny = dy / r;
  res = evaluate(p, delta, xi_trial);
  out[0] = res.fn * nx + res.ft * ny;
  out[1] = res.fn * ny - res.ft * nx;
  out[2] = res.ft;
  return res;
}

// Stiffness block of one disk-disk contact, K = -dG_i/dq, where
// G_i = (F_x, F_y, T_i/R_i) on disk i and
// q = (x_i, y_i, R_i th_i, x_j, y_j, R_j th_j).  Row-major 3 x 6.
// The rows for disk j follow from F_j = -F_i and T_j/R_j = T_i/R_i:
// rows 0,1 of j are minus rows 0,1 of i, row 2 of j equals row 2 of i.
// Derivatives are taken along the history-update rule (see header).
inline void pair_stiffness(const Params &p, double dx, double dy, double ri, double rj,
                           double xi, double K[18])
{
  for (int a = 0; a < 18; a++) K[a] = 0.0;
  const double r = std::sqrt(dx * dx + dy * dy);
  const double delta = ri + rj - r;
  if (delta <= 0.0) return;
  const double n[2] = {dx / r, dy / r};
  const double s[2] = {n[1], -n[0]};
  const Response res = evaluate(p, delta, xi);
  const Derivs d = derivatives(p, delta, xi);
  const double fnr = res.fn / r, ftr = res.ft / r;
  // dF/dr_i (2x2) and dG/dr_i (1x2)
  for (int a = 0; a < 2; a++) {
    for (int b = 0; b < 2; b++) {
      const double dF = -d.dfn_ddelta * n[a] * n[b] + fnr * s[a] * s[b]
        - d.dft_ddelta * s[a] * n[b] + d.dft_dxi * s[a] * s[b] - ftr * n[a] * s[b];
      K[a * 6 + b] = -dF;
      K[a * 6 + 3 + b] = dF;
    }
    const double dG = -d.dft_ddelta * n[a] + d.dft_dxi * s[a];
    K[2 * 6 + a] = -dG;
    K[2 * 6 + 3 + a] = dG;
    // dF/dphi_i = dF/dphi_j = dft/dxi s
    K[a * 6 + 2] = -d.dft_dxi * s[a];
    K[a * 6 + 5] = -d.dft_dxi * s[a];
  }
  K[2 * 6 + 2] = -d.dft_dxi;
  K[2 * 6 + 5] = -d.dft_dxi;
}

// Generalized force on a disk from a flat wall below it at y_w:
// delta = R - (y - y_w), n = +y, s = +x.  out = (F_x, F_y, T/R).
inline Response wall_force(const Params &p, double delta, double xi_trial, double out[3])
{
  Response res = {0.0, 0.0, 0.0, 0.0, 0};
  out[0] = out[1] = out[2] = 0.0;
  if (delta <= 0.0) return res;
  res = evaluate(p, delta, xi_trial);
  out[0] = res.ft;
  out[1] = res.fn;
  out[2] = res.ft;
  return res;
}

// Stiffness block of one disk-wall contact, K = -dG/dq with
// q = (x, y, R th).  Row-major 3 x 3.
inline void wall_stiffness(const Params &p, double delta, double xi, double K[9])
{
  for (int a = 0; a < 9; a++) K[a] = 0.0;
  if (delta <= 0.0) return;
  const Derivs d = derivatives(p, delta, xi);
  // n = (0,1), s = (1,0); d delta/dy = -1, d xi/dx = 1, d xi/dphi = 1;
  // F_x = ft, F_y = fn, G = ft.
  K[0] = -d.dft_dxi;      // -dFx/dx
  K[1] = d.dft_ddelta;    // -dFx/dy
  K[2] = -d.dft_dxi;      // -dFx/dphi
  K[4] = d.dfn_ddelta;    // -dFy/dy
  K[6] = -d.dft_dxi;      // -dG/dx
  K[7] = d.dft_ddelta;    // -dG/dy
  K[8] = -d.dft_dxi;      // -dG/dphi
}

}    // namespace MindlinSmooth

#endif
