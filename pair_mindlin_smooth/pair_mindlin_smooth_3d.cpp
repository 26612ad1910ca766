/* ----------------------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin), 3d loop

   The contract of the 2d loop (pair_mindlin_smooth.cpp): a FULL neighbor
   list, each owned atom updating only its own side of each contact, the
   contacts of an atom summed in ascending partner tag, the touching band.
   The law is that of mindlin_smooth_kernel_3d.h: the stored tangential
   displacement t (mindlin_tx, mindlin_ty, mindlin_tz) is projected
   onto the current tangent plane with its length kept, advanced by the
   slip of the step and capped at t*; the torque is (-R_i n) x F_t.
------------------------------------------------------------------------- */

#include "pair_mindlin_smooth.h"

#include "fix_mindlin_history.h"
#include "mindlin_smooth_contacts.h"
#include "mindlin_smooth_kernel_3d.h"

#include "atom.h"
#include "domain.h"
#include "error.h"
#include "neigh_list.h"
#include "update.h"

#include <cmath>

using namespace LAMMPS_NS;
using MindlinSmooth::find_slot;
using MindlinSmooth::touch_band;
using MindlinSmooth::touch_base;

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::compute_3d()
{
  find_history();
  int **partner = atom->iarray[idx_partner];
  double **tc[3] = {atom->darray[idx_t3[0]], atom->darray[idx_t3[1]], atom->darray[idx_t3[2]]};

  double **x = atom->x;
  double **v = atom->v;
  double **f = atom->f;
  double **omega = atom->omega;
  double **torque = atom->torque;
  const double *radius = atom->radius;
  const int *type = atom->type;
  const tagint *tag = atom->tag;

  const int update_history = (update->setupflag == 0);
  const double dt = update->dt;
  const double tbase = touch_base(domain);

  int nslot = ncol;
  if ((int) contacts3.size() < nslot) contacts3.resize(nslot);
  Contact3 *cs = contacts3.data();
  int ncap = (int) contacts3.size();

  for (int ii = 0; ii < list->inum; ii++) {
    const int i = list->ilist[ii];
    const int itype = type[i];
    const double radi = radius[i];
    const int *jlist = list->firstneigh[i];
    const int jnum = list->numneigh[i];
    if (jnum > ncap) {
      contacts3.resize(MAX((size_t) jnum, 2 * contacts3.size()));
      ncap = (int) contacts3.size();
      cs = contacts3.data();
    }
    const int *ipartner = partner[i];
    int nc = 0;

    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      const double del[3] = {x[i][0] - x[j][0], x[i][1] - x[j][1], x[i][2] - x[j][2]};
      const double rsq = MindlinSmooth::dot3(del, del);
      const double radsum = radi + radius[j];
      const double tau = touch_band(tbase, radsum);
      const double rmax = radsum + tau;
      if (rsq >= rmax * rmax) continue;

      if (rsq == 0.0)
        error->one(FLERR,
                   "Pair style mindlin/smooth: atoms {} and {} have coincident centres "
                   "(no contact normal)",
                   tag[i], tag[j]);
      const int jtype = type[j];
      const double r = sqrt(rsq);
      const double n[3] = {del[0] / r, del[1] / r, del[2] / r};
      const int slot = find_slot(ipartner, nslot, tag[j]);
      const double gap = radsum - r;
      const bool band = (gap <= tau && gap >= -tau);
      const bool listed = band ? (slot >= 0) : (gap > 0.0);
      if (!listed && !(gap > 0.0)) continue;
      // inside the band: normal force only and t = 0 (as in 2d)
      const double delta = MAX(gap, 0.0);
      double stored[3] = {0.0, 0.0, 0.0};
      if (slot >= 0 && !band)
        for (int a = 0; a < 3; a++) stored[a] = tc[a][i][slot];
      const bool advance = update_history && !band;
      double slip[3] = {0.0, 0.0, 0.0};
      if (advance) {
        const double dv[3] = {v[i][0] - v[j][0], v[i][1] - v[j][1], v[i][2] - v[j][2]};
        double w[3];
        for (int a = 0; a < 3; a++) w[a] = radi * omega[i][a] + radius[j] * omega[j][a];
        MindlinSmooth::slip3(n, dv, w, slip);
      }
      const MindlinSmooth::Params p = {kn[itype][jtype], kt[itype][jtype], mu[itype][jtype]};
      const MindlinSmooth::Response3 res =
          MindlinSmooth::step3(p, delta, n, stored, slip, dt, advance);

      Contact3 &c = cs[nc++];
      c.tag = tag[j];
      for (int a = 0; a < 3; a++) {
        c.t[a] = res.t[a];
        c.f[a] = res.fn * n[a] + res.ft[a];
        c.del[a] = del[a];
      }
      MindlinSmooth::torque3(radi, n, res.ft, c.tq);
      c.en = 0.4 * res.fn * delta;    // Hertz elastic energy (2/5) k_n delta^{5/2}
      c.listed = listed;
    }

    if (nc > nslot && !history) too_many_contacts(tag[i]);
    const int dup = MindlinSmooth::sort_by_tag(cs, nc);
    if (dup >= 0) two_images(tag[i], cs[dup].tag);

    for (int a = 0; a < nc; a++) {
      const Contact3 &c = cs[a];
      for (int k = 0; k < 3; k++) {
        f[i][k] += c.f[k];
        torque[i][k] += c.tq[k];
      }
      if (evflag)
        ev_tally_xyz_full(i, c.en, 0.0, c.f[0], c.f[1], c.f[2], c.del[0], c.del[1], c.del[2]);
    }

    if (update_history) {
      if (nc > nslot) {
        history->reserve(nc);
        find_history();
        partner = atom->iarray[idx_partner];
        for (int k = 0; k < 3; k++) tc[k] = atom->darray[idx_t3[k]];
        nslot = ncol;
      }
      int nl = 0;
      for (int a = 0; a < nc; a++) {
        if (!cs[a].listed) continue;
        partner[i][nl] = cs[a].tag;
        for (int k = 0; k < 3; k++) tc[k][i][nl] = cs[a].t[k];
        nl++;
      }
      for (int a = nl; a < nslot; a++) {
        partner[i][a] = 0;
        for (int k = 0; k < 3; k++) tc[k][i][a] = 0.0;
      }
    }
  }
}

/* ----------------------------------------------------------------------
   single() in 3d: the stored t projected onto the current tangent plane,
   not advanced; never changes state.
   svector: F_t,x  F_t,y  u  t_x  t_y  F_t,z  t_z  (on atom i)
------------------------------------------------------------------------- */

double PairMindlinSmooth::single_3d(int i, int j, int itype, int jtype, double rsq,
                                    double &fforce)
{
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  fforce = 0.0;
  const double radsum = atom->radius[i] + atom->radius[j];
  const double tau = touch_band(touch_base(domain), radsum);
  const double rmax = radsum + tau;
  if (rsq >= rmax * rmax || rsq == 0.0) return 0.0;

  if (idx_t3[0] < 0) find_history();
  const int slot = find_slot(atom->iarray[idx_partner][i], atom->icols[idx_partner], atom->tag[j]);
  const double r = sqrt(rsq);
  const double gap = radsum - r;
  if (!(gap > 0.0)) return 0.0;
  const double zero[3] = {0.0, 0.0, 0.0};
  double stored[3] = {0.0, 0.0, 0.0};
  if (slot >= 0 && gap > tau)
    for (int a = 0; a < 3; a++) stored[a] = atom->darray[idx_t3[a]][i][slot];

  double **x = atom->x;
  const double n[3] = {(x[i][0] - x[j][0]) / r, (x[i][1] - x[j][1]) / r,
                       (x[i][2] - x[j][2]) / r};
  const MindlinSmooth::Params p = {kn[itype][jtype], kt[itype][jtype], mu[itype][jtype]};
  const MindlinSmooth::Response3 res = MindlinSmooth::step3(p, gap, n, stored, zero, 0.0, false);

  fforce = res.fn / r;
  svector[0] = res.ft[0];
  svector[1] = res.ft[1];
  svector[2] = res.u;
  svector[3] = res.t[0];
  svector[4] = res.t[1];
  svector[5] = res.ft[2];
  svector[6] = res.t[2];
  return 0.4 * res.fn * gap;
}
