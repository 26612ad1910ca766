/* ----------------------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin), 3d loop

   The contract of the 2d loop (pair_mindlin_smooth.cpp): a FULL neighbor
   list, each owned atom updating only its own side of each contact, the
   contacts of an atom summed in ascending partner tag, the touching band.
   The law is that of mindlin_smooth_kernel_3d.h: the stored tangential
   displacement t (mindlin_tx, mindlin_ty, mindlin_tz) is projected
   onto the current tangent plane with its length kept, advanced by the
   slip of the step and capped at t*; the torque is (-R_i n) x F_t.

   A contact of two owned spheres is computed once, by the one that comes
   first in the list; the second takes its mirror image.  The kernel is
   odd in n, t and the relative velocity, so the side the second sphere
   would compute itself is that image bit for bit (mindlin_smooth_kernel_3d.h,
   "Mirror symmetry") -- provided its own stored history is the mirror
   image of the first side's.  The second sphere checks that against its
   own history (for every contact, every step) and computes its side
   itself where it is not so.  Contacts with ghost atoms are computed by
   each owned side.  Each atom then sums its contacts in ascending partner
   tag as before: the forces, torques and histories are those of
   computing every side separately (up to the sign of a zero), for any
   number of ranks and any order of the atoms.
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

namespace {

// Image3::flags: the first side's contact, history entry, band, slot
enum { HAS_CONTACT = 1, LISTED = 2, IN_BAND = 4, HAS_SLOT = 8 };

// what one side of a contact reads
struct Atoms3 {
  double **x, **v, **omega;
  const double *radius;
  const int *type;
  double **kn, **kt, **mu;
  double dt;
  bool update_history;
};

// One side of the contact of sphere i with sphere j (del = x_i - x_j,
// r = |del|, overlap gap, in the touching band or not, i's stored history,
// zero if none): the kernel's step, the force on i and n x F_t.
// (always inlined: a call in the pair loop spills its registers)
__attribute__((always_inline)) inline void
contact_side(const Atoms3 &a, int i, int j, const double del[3], double r, double gap, bool band,
             const double stored[3], bool listed, PairMindlinSmooth::Contact3 &c)
{
  const double n[3] = {del[0] / r, del[1] / r, del[2] / r};
  // inside the band: normal force only and t = 0 (as in 2d)
  const double delta = MAX(gap, 0.0);
  const bool advance = a.update_history && !band;
  double slip[3] = {0.0, 0.0, 0.0};
  if (advance) {
    const double *vi = a.v[i], *vj = a.v[j], *oi = a.omega[i], *oj = a.omega[j];
    const double dv[3] = {vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]};
    const double ri = a.radius[i], rj = a.radius[j];
    const double w[3] = {ri * oi[0] + rj * oj[0], ri * oi[1] + rj * oj[1],
                         ri * oi[2] + rj * oj[2]};
    MindlinSmooth::slip3(n, dv, w, slip);
  }
  const int it = a.type[i], jt = a.type[j];
  const MindlinSmooth::Params p = {a.kn[it][jt], a.kt[it][jt], a.mu[it][jt]};
  const MindlinSmooth::Response3 res =
      MindlinSmooth::step3(p, delta, n, stored, slip, a.dt, advance);
  for (int k = 0; k < 3; k++) {
    c.t[k] = res.t[k];
    c.f[k] = res.fn * n[k] + res.ft[k];
    c.del[k] = del[k];
  }
  MindlinSmooth::cross3(n, res.ft, c.nxf);
  c.en = 0.4 * res.fn * delta;    // Hertz elastic energy (2/5) k_n delta^{5/2}
  c.listed = listed;
}

// stored history of one side: its slot's t, or zero (no slot, or in the band);
// row[k] = the side's row of mindlin_tx, _ty, _tz
inline void stored_t(const double *const row[3], int slot, bool band, double out[3])
{
  for (int k = 0; k < 3; k++) out[k] = (slot >= 0 && !band) ? row[k][slot] : 0.0;
}

// Slots that can stand for the canonical order (bits of a 64-bit mask).
constexpr int SLOT_ORDER_MAX = 64;

// Notes the slot of contact number c of an atom for slot_order(): pos[s]
// = the contact in slot s, mask = the slots taken, all = every contact
// so far has a slot below SLOT_ORDER_MAX.
inline void note_slot(int slot, int c, int *pos, unsigned long long &mask, bool &all)
{
  if ((unsigned) slot < (unsigned) SLOT_ORDER_MAX) {
    pos[slot] = c;
    mask |= 1ull << slot;
  } else
    all = false;
}

// The canonical order read off the history slots, without a sort: true
// when every contact holds a slot, together they hold slots 0..nc-1 (nc
// contacts, nc distinct slots) and their tags ascend along the slots.
// The history is written in ascending tag, so this is the common case:
// no contact made or lost since the last step, none in the touching band
// without a slot.  Anything else (or slots not in order, as a driver may
// set them) takes rank_by_tag().
inline bool slot_order(const PairMindlinSmooth::Contact3 *cs, int nc, const int *pos,
                       unsigned long long mask, bool all)
{
  if (!all || nc > SLOT_ORDER_MAX) return false;
  const unsigned long long full = (nc == SLOT_ORDER_MAX) ? ~0ull : (1ull << nc) - 1;
  if (mask != full) return false;
  for (int a = 1; a < nc; a++)
    if (!(cs[pos[a - 1]].tag < cs[pos[a]].tag)) return false;
  return true;
}

// The canonical order of one atom's contacts, ascending partner tag:
// order[m] = the index of the m-th.  Each contact's place is the number of
// contacts with a smaller tag, counted without branches (cheaper than a
// sort for the ~6 contacts of a sphere, whose tags come in no order).
// Returns a tag that occurs twice (the smallest), 0 if none.
inline tagint rank_by_tag(const PairMindlinSmooth::Contact3 *cs, int nc, int *order)
{
  tagint dup = 0;
  for (int a = 0; a < nc; a++) {
    const tagint ta = cs[a].tag;
    int below = 0, same = 0;
    for (int b = 0; b < nc; b++) {
      below += (cs[b].tag < ta);
      same += (cs[b].tag == ta);
    }
    if (same > 1) {
      if (dup == 0 || ta < dup) dup = ta;
      continue;
    }
    order[below] = a;
  }
  return dup;
}

}    // namespace

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::compute_3d()
{
  find_history();
  int **partner = atom->iarray[idx_partner];
  double **tc[3] = {atom->darray[idx_t3[0]], atom->darray[idx_t3[1]], atom->darray[idx_t3[2]]};

  double **x = atom->x;
  double **f = atom->f;
  double **torque = atom->torque;
  const double *radius = atom->radius;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;

  const int update_history = (update->setupflag == 0);
  const Atoms3 at = {x,  atom->v, atom->omega, radius, atom->type, kn, kt, mu, update->dt,
                     update_history != 0};
  const double tbase = touch_base(domain);
  int nslot = ncol;

  // Position of each owned atom in the list (-1: not in it).  An image per
  // pair of owned neighbours at most; scratch space for one atom's
  // contacts, as many as its neighbours (the full list is symmetric).
  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;
  if ((int) rank3.size() < nlocal) {
    rank3.resize(atom->nmax);
    head3.resize(atom->nmax);
  }
  int *rank = rank3.data(), *head = head3.data();
  for (int i = 0; i < nlocal; i++) rank[i] = head[i] = -1;
  int total = 0, most = 0;
  bool inorder = true;    // ilist[ii] == ii: the position is the index itself
  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    rank[i] = ii;
    inorder = inorder && (i == ii);
    total += numneigh[i];
    most = MAX(most, numneigh[i]);
  }
  if ((int) images3.size() < total / 2 + 1) images3.resize(total / 2 + total / 8 + 1);
  if ((int) contacts3.size() < most) {
    contacts3.resize(most);
    order3.resize(most);
  }
  Image3 *images = images3.data();
  const int maximage = (int) images3.size();
  int nimage = 0;
  Contact3 *cs = contacts3.data();
  int *order = order3.data();

  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const tagint itag = tag[i];
    const double radi = radius[i];
    const double xi[3] = {x[i][0], x[i][1], x[i][2]};
    const int *jlist = firstneigh[i];
    const int jnum = numneigh[i];
    const int *ipartner = partner[i];
    const double *const itc[3] = {tc[0][i], tc[1][i], tc[2][i]};
    int nc = 0;
    int pos[SLOT_ORDER_MAX];    // slot_order(): the contact in each slot
    unsigned long long taken = 0;
    bool allslots = true;

    // the contacts computed here: with ghosts, and with owned atoms later
    // in the list (which get the image)
    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      const bool once = inorder ? (j < nlocal) : (j < nlocal && rank[j] >= 0);
      if (once && (inorder ? j : rank[j]) < ii) continue;    // computed by j: image below

      const double del[3] = {xi[0] - x[j][0], xi[1] - x[j][1], xi[2] - x[j][2]};
      const double rsq = MindlinSmooth::dot3(del, del);
      const double radsum = radi + radius[j];
      const double tau = touch_band(tbase, radsum);
      const double rmax = radsum + tau;
      if (rsq >= rmax * rmax) continue;

      if (rsq == 0.0)
        error->one(FLERR,
                   "Pair style mindlin/smooth: atoms {} and {} have coincident centres "
                   "(no contact normal)",
                   itag, tag[j]);
      const double r = sqrt(rsq);
      const double gap = radsum - r;
      const bool band = (gap <= tau && gap >= -tau);
      const int slot = find_slot(ipartner, nslot, tag[j]);
      double stored[3];
      stored_t(itc, slot, band, stored);
      const bool listed = band ? (slot >= 0) : (gap > 0.0);
      const bool has = listed || gap > 0.0;
      Contact3 &c = cs[nc];
      if (has) {
        c.tag = tag[j];
        contact_side(at, i, j, del, r, gap, band, stored, listed, c);
        note_slot(slot, nc, pos, taken, allslots);
        nc++;
      }
      if (!once) continue;
      if (nimage == maximage)
        error->one(FLERR,
                   "Pair style mindlin/smooth: more contact images than half the neighbour "
                   "pairs (the neighbor list is not symmetric)");
      Image3 &im = images[nimage];
      im.tag = itag;
      im.i = i;
      im.flags = (has ? HAS_CONTACT : 0) | (listed ? LISTED : 0) | (band ? IN_BAND : 0) |
          (slot >= 0 ? HAS_SLOT : 0);
      im.next = head[j];
      head[j] = nimage++;
      for (int k = 0; k < 3; k++) im.stored[k] = stored[k];
      if (has) {
        for (int k = 0; k < 3; k++) {
          im.t[k] = c.t[k];
          im.f[k] = c.f[k];
          im.nxf[k] = c.nxf[k];
        }
        im.en = c.en;
      }
    }

    // the contacts computed by atoms earlier in the list: the mirror image
    // where i's own history is the image of theirs, else i's side anew
    for (int a = head[i]; a >= 0; a = images[a].next) {
      const Image3 &im = images[a];
      const bool band = (im.flags & IN_BAND) != 0;
      const int slot = find_slot(ipartner, nslot, im.tag);
      double stored[3];
      stored_t(itc, slot, band, stored);
      const bool mirror = band ? (((im.flags & HAS_SLOT) != 0) == (slot >= 0))
                               : (stored[0] == -im.stored[0] && stored[1] == -im.stored[1] &&
                                  stored[2] == -im.stored[2]);
      const int j = im.i;
      if (mirror) {
        if (!(im.flags & HAS_CONTACT)) continue;
        note_slot(slot, nc, pos, taken, allslots);
        Contact3 &c = cs[nc++];
        c.tag = im.tag;
        c.listed = (im.flags & LISTED) != 0;
        for (int k = 0; k < 3; k++) {
          c.t[k] = -im.t[k];
          c.f[k] = -im.f[k];
          c.nxf[k] = im.nxf[k];    // n x F_t: both factors change sign
        }
        c.en = im.en;
        if (evflag)
          for (int k = 0; k < 3; k++) c.del[k] = xi[k] - x[j][k];
        continue;
      }
      // the same geometry as j's (del negated exactly)
      const double del[3] = {xi[0] - x[j][0], xi[1] - x[j][1], xi[2] - x[j][2]};
      const double r = sqrt(MindlinSmooth::dot3(del, del));
      const double gap = (radi + radius[j]) - r;
      const bool listed = band ? (slot >= 0) : (gap > 0.0);
      if (!(listed || gap > 0.0)) continue;
      note_slot(slot, nc, pos, taken, allslots);
      Contact3 &c = cs[nc++];
      c.tag = im.tag;
      contact_side(at, i, j, del, r, gap, band, stored, listed, c);
    }

    if (nc > nslot && !history) too_many_contacts(itag);
    const int *ord = pos;
    if (!slot_order(cs, nc, pos, taken, allslots)) {
      const tagint dup = rank_by_tag(cs, nc, order);
      if (dup > 0) two_images(itag, dup);
      ord = order;
    }

    // summed in registers: the same additions in the same order as into
    // f[i] and torque[i] directly, which the compiler would have to
    // reload after every store (they might alias the contacts)
    double fi[3] = {f[i][0], f[i][1], f[i][2]};
    double ti[3] = {torque[i][0], torque[i][1], torque[i][2]};
    for (int a = 0; a < nc; a++) {
      const Contact3 &c = cs[ord[a]];
      for (int k = 0; k < 3; k++) {
        fi[k] += c.f[k];
        ti[k] += -radi * c.nxf[k];
      }
      if (evflag)
        ev_tally_xyz_full(i, c.en, 0.0, c.f[0], c.f[1], c.f[2], c.del[0], c.del[1], c.del[2]);
    }
    for (int k = 0; k < 3; k++) {
      f[i][k] = fi[k];
      torque[i][k] = ti[k];
    }

    if (update_history) {
      if (nc > nslot) {
        history->reserve(nc);
        find_history();
        partner = atom->iarray[idx_partner];
        for (int k = 0; k < 3; k++) tc[k] = atom->darray[idx_t3[k]];
        nslot = ncol;
      }
      int *prow = partner[i];
      double *const trow[3] = {tc[0][i], tc[1][i], tc[2][i]};
      int nl = 0;
      for (int a = 0; a < nc; a++) {
        const Contact3 &c = cs[ord[a]];
        if (!c.listed) continue;
        prow[nl] = c.tag;
        for (int k = 0; k < 3; k++) trow[k][nl] = c.t[k];
        nl++;
      }
      // the slots that held a contact and hold none now: slots are packed
      // and, once cleared whole (packed3), zero from the first empty one on,
      // so the old entries past nl end at the first zero
      for (int a = nl; a < nslot && (!packed3 || prow[a] != 0); a++) {
        prow[a] = 0;
        for (int k = 0; k < 3; k++) trow[k][a] = 0.0;
      }
    }
  }
  if (update_history) packed3 = true;
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
