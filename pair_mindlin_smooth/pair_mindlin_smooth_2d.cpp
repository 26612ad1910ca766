/* ----------------------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin), 2d loop

   Each owned atom i loops over the FULL neighbor list and updates only its
   own side of each contact (the history slot matched by partner tag); its
   contacts are summed in ascending partner tag (pair_mindlin_smooth.cpp).
   The law is that of mindlin_smooth_kernel.h: the signed scalar xi along
   s = (n_y, -n_x), advanced by the slip of the step.
------------------------------------------------------------------------- */

#include "pair_mindlin_smooth.h"

#include "fix_mindlin_history.h"
#include "mindlin_smooth_contacts.h"
#include "mindlin_smooth_kernel.h"

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

void PairMindlinSmooth::compute_2d()
{
  // re-read: the arrays move when atoms are added or sorted
  find_history();
  int **partner = atom->iarray[idx_partner];
  double **tdisp = atom->darray[idx_t];

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

  const int inum = list->inum;
  // The scratch space holds at least as many contacts as the atom has
  // neighbours: grown (rarely) before the pair loop, never inside it, and
  // the limit of a fix property/atom with fixed columns checked after it
  // (a capacity test with a returning call in the pair loop cost registers:
  // measured 7 % more pair time)
  int nslot = ncol;    // history columns
  Contact *cs = contacts.data();
  int ncap = (int) contacts.size();
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;

  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const int itype = type[i];
    const double xi0 = x[i][0], yi0 = x[i][1], radi = radius[i];
    const int *jlist = firstneigh[i];
    const int jnum = numneigh[i];
    if (jnum > ncap) {
      ncap = grow_scratch(jnum);
      cs = contacts.data();
    }
    const int *ipartner = partner[i];
    const double *itdisp = tdisp[i];
    int nc = 0;

    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      const double delx = xi0 - x[j][0];
      const double dely = yi0 - x[j][1];
      const double rsq = delx * delx + dely * dely;
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
      const double nx = delx / r, ny = dely / r;
      const int slot = find_slot(ipartner, nslot, tag[j]);
      const double gap = radsum - r;
      const bool band = (gap <= tau && gap >= -tau);
      const bool listed = band ? (slot >= 0) : (gap > 0.0);
      if (!listed && !(gap > 0.0)) continue;
      // the normal force of this side's own overlap, always; inside the band
      // no tangential force and xi = 0, so that the two sides' histories agree
      const double delta = MAX(gap, 0.0);
      double xi = (slot >= 0 && !band) ? itdisp[slot] : 0.0;
      if (update_history && !band) {
        // MindlinSmooth::step written out, the slip computed only when the
        // history advances (measured: 8 % less pair time than calling step)
        // slip of the contact point of i relative to j along s = (ny, -nx)
        const double vs = ny * (v[i][0] - v[j][0]) - nx * (v[i][1] - v[j][1]);
        xi += dt * (vs + (radi * omega[i][2] + radius[j] * omega[j][2]));
      }
      const MindlinSmooth::Params p = {kn[itype][jtype], kt[itype][jtype], mu[itype][jtype]};
      const MindlinSmooth::Response res = MindlinSmooth::evaluate(p, delta, xi);

      Contact &c = cs[nc++];
      c.tag = tag[j];
      c.xi = res.xi;
      c.fx = res.fn * nx + res.ft * ny;
      c.fy = res.fn * ny - res.ft * nx;
      c.tz = radi * res.ft;
      c.en = 0.4 * res.fn * delta;    // Hertz elastic energy (2/5) k_n delta^{5/2}
      c.delx = delx;
      c.dely = dely;
      c.listed = listed;
    }

    if (nc > nslot && !history) too_many_contacts(tag[i]);

    // canonical order: ascending partner tag
    const int dup = MindlinSmooth::sort_by_tag(cs, nc);
    if (dup >= 0) two_images(tag[i], cs[dup].tag);

    for (int a = 0; a < nc; a++) {
      const Contact &c = cs[a];
      f[i][0] += c.fx;
      f[i][1] += c.fy;
      torque[i][2] += c.tz;
      if (evflag) ev_tally_xyz_full(i, c.en, 0.0, c.fx, c.fy, 0.0, c.delx, c.dely, 0.0);
    }

    if (update_history) {
      if (nc > nslot) {
        history->reserve(nc);
        find_history();
        partner = atom->iarray[idx_partner];
        tdisp = atom->darray[idx_t];
        nslot = ncol;
      }
      int nl = 0;
      for (int a = 0; a < nc; a++) {
        if (!cs[a].listed) continue;
        partner[i][nl] = cs[a].tag;
        tdisp[i][nl] = cs[a].xi;
        nl++;
      }
      for (int a = nl; a < nslot; a++) {
        partner[i][a] = 0;
        tdisp[i][a] = 0.0;
      }
    }
  }
}
