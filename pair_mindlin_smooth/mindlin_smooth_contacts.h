/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: the per-atom contact bookkeeping of pair mindlin/smooth
   shared by its 2D and 3D loops (pair_mindlin_smooth_2d.cpp,
   pair_mindlin_smooth_3d.cpp): history slots, the touching band, the
   canonical order of one atom's contacts.
------------------------------------------------------------------------- */

#ifndef REMOTE_TRIGGER_MINDLIN_SMOOTH_CONTACTS_H
#define REMOTE_TRIGGER_MINDLIN_SMOOTH_CONTACTS_H

#include "domain.h"
#include "lmptype.h"

#include <cfloat>
#include <cmath>

namespace MindlinSmooth {

/* ----------------------------------------------------------------------
   slot of partner jtag among one atom's ncol history slots, -1 if none
------------------------------------------------------------------------- */

inline int find_slot(const int *partner, int ncol, LAMMPS_NS::tagint jtag)
{
  for (int k = 0; k < ncol; k++) {
    if (partner[k] == jtag) return k;
    if (partner[k] == 0) break;    // slots are packed
  }
  return -1;
}

/* ----------------------------------------------------------------------
   touching band.  Each disk of a pair decides the contact from its own
   copy of the geometry, and across a periodic boundary each sees the
   other's image x +- L, rounded: at an overlap within a few ulps of the
   coordinates the two tests can disagree (measured: 31 of 81 positions
   one ulp apart around delta = 0 in a box 47.6 wide), and one side would
   keep a history entry that the other drops.  A disk held by a single
   contact is drawn to exactly that place (its force-free position is
   delta = 0).  Within |delta| <= tau a pair therefore stays listed in the
   history, or unlisted, as its history records -- the same on both sides --
   with xi = 0 and no tangential force (so that the two sides' xi agree
   too); the normal force is each side's own k_n delta^(3/2) for delta > 0,
   as everywhere.  Outside the band the overlap decides.  tau depends only
   on the box and the two radii, so both sides use the same tau; it is 64
   ulps of the largest coordinate a ghost can have, ~1e-12 for a box of 50,
   where the tangential force left out is below mu k_n tau^(3/2) ~ 1e-13.
   The box extent is taken over the simulation's dimensions (x, y in 2D).
------------------------------------------------------------------------- */

static const double TOUCH_ULPS = 64.0;

inline double touch_base(const LAMMPS_NS::Domain *domain)
{
  double ext = 0.0, prd = 0.0;
  for (int d = 0; d < domain->dimension; d++) {
    ext = std::fmax(ext, std::fabs(domain->boxlo[d]));
    ext = std::fmax(ext, std::fabs(domain->boxhi[d]));
    prd = std::fmax(prd, domain->prd[d]);
  }
  return ext + prd;
}

inline double touch_band(double base, double radsum)
{
  return TOUCH_ULPS * DBL_EPSILON * (base + radsum);
}

/* ----------------------------------------------------------------------
   one atom's contacts in canonical order, ascending partner tag
   (insertion sort: few contacts, mostly in order already); returns the
   index of a contact whose tag repeats the previous one, -1 if none
------------------------------------------------------------------------- */

template <class C> int sort_by_tag(C *cs, int nc)
{
  for (int a = 1; a < nc; a++) {
    const C key = cs[a];
    int b = a - 1;
    while (b >= 0 && cs[b].tag > key.tag) {
      cs[b + 1] = cs[b];
      b--;
    }
    cs[b + 1] = key;
  }
  for (int a = 1; a < nc; a++)
    if (cs[a].tag == cs[a - 1].tag) return a;
  return -1;
}

}    // namespace MindlinSmooth

#endif
