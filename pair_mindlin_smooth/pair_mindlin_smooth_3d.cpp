/* ----------------------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin), 3d loop

   The contract of the 2d loop (pair_mindlin_smooth_2d.cpp): a FULL neighbor
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
#include "neighbor.h"
#include "update.h"

#include <cmath>
#include <type_traits>

using namespace LAMMPS_NS;
using MindlinSmooth::find_slot;
using MindlinSmooth::touch_band;
using MindlinSmooth::touch_base;

namespace {

// Image3::flags: the first side's contact, history entry, band, slot
enum { HAS_CONTACT = 1, LISTED = 2, IN_BAND = 4, HAS_SLOT = 8 };

// Entry3::img of a neighbour computed by each side, with no image (even, so
// that img & 1 tells only the second side of a pair)
constexpr int ALONE = -2;

// what one side of a contact reads: the per-atom vectors as the rows of one
// block each (LAMMPS allocates x, v, omega with memory->grow(), a block of
// nmax rows of 3 and a row pointer to each): x + 3 j is x[j], one load less
// on the way to a neighbour's data
struct Atoms3 {
  const double *x, *v, *omega;
  const double *radius;
  const int *type;
  double dt;
  bool update_history;
  bool evflag;    // energy or virial tallied this step
};

// what it reads of its own sphere i, fetched once per sphere
struct Own3 {
  const double *v, *omega;
  double radius;
  const double *kn, *kt, *mu;    // the rows of i's type
};

// One side of the contact of sphere i with sphere j (del = x_i - x_j,
// r = |del|, overlap gap, in the touching band or not, i's stored history,
// zero if none): the kernel's step, the force on i and n x F_t.
// (always inlined: a call in the pair loop spills its registers)
__attribute__((always_inline)) inline void
contact_side(const Atoms3 &a, const Own3 &o, int j, const double del[3], double r, double gap,
             bool band, const double stored[3], bool listed, PairMindlinSmooth::Contact3 &c)
{
  const double n[3] = {del[0] / r, del[1] / r, del[2] / r};
  // inside the band: normal force only and t = 0 (as in 2d)
  const double delta = MAX(gap, 0.0);
  const bool advance = a.update_history && !band;
  double slip[3] = {0.0, 0.0, 0.0};
  if (advance) {
    const double *vi = o.v, *vj = a.v + 3 * (size_t) j, *oi = o.omega,
                 *oj = a.omega + 3 * (size_t) j;
    const double dv[3] = {vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]};
    const double ri = o.radius, rj = a.radius[j];
    const double w[3] = {ri * oi[0] + rj * oj[0], ri * oi[1] + rj * oj[1],
                         ri * oi[2] + rj * oj[2]};
    MindlinSmooth::slip3(n, dv, w, slip);
  }
  const int jt = a.type[j];
  const MindlinSmooth::Params p = {o.kn[jt], o.kt[jt], o.mu[jt]};
  const MindlinSmooth::Response3 res =
      MindlinSmooth::step3(p, delta, n, stored, slip, a.dt, advance);
  for (int k = 0; k < 3; k++) {
    c.t[k] = res.t[k];
    c.f[k] = res.fn * n[k] + res.ft[k];
  }
  MindlinSmooth::cross3(n, res.ft, c.nxf);
  if (a.evflag) {
    // what the energy and virial tally reads
    for (int k = 0; k < 3; k++) c.del[k] = del[k];
    c.en = 0.4 * res.fn * delta;    // Hertz elastic energy (2/5) k_n delta^{5/2}
  }
  c.listed = listed;
}

// stored history of one side: its slot's t, or zero (no slot, or in the band);
// row[k] = the side's row of mindlin_tx, _ty, _tz
inline void stored_t(const double *const row[3], int slot, bool band, double out[3])
{
  if (slot >= 0 && !band)
    for (int k = 0; k < 3; k++) out[k] = row[k][slot];
  else
    for (int k = 0; k < 3; k++) out[k] = 0.0;
}

// Slot of partner jtag in one atom's history row (find_slot()'s answer),
// for partners asked in ascending tag: a walk along the row, which this
// loop writes in ascending tag, from where the previous one stopped (k).
// A tag not met on the way is looked for in the whole row (a new contact,
// or a row a driver or a data file wrote in another order).
inline int walk_slot(const int *row, int nslot, int &k, tagint jtag)
{
  // most often the contacts are those of the row: jtag is the next one
  if (k < nslot && row[k] == jtag) return k++;
  using utag = std::make_unsigned<tagint>::type;
  // 0 < row[k] < jtag in one comparison (tags are > 0, an empty slot is 0)
  while (k < nslot && (utag) (row[k] - 1) < (utag) (jtag - 1)) k++;
  if (k < nslot && row[k] == jtag) return k;
  return find_slot(row, nslot, jtag);
}

}    // namespace

/* ----------------------------------------------------------------------
   The full neighbor list as the 3d loop walks it, made again whenever
   LAMMPS builds the list (and after every init): per owned atom (position
   ii in the list) its neighbours in ascending tag, so that its contacts
   come out in the canonical order with no sort, and the slot of each
   partner is found by one walk along the history row.  Each pair of owned
   atoms gets an index, in the order the first of the two meets it: the
   entry of the first atom says 2 * index (it computes the contact and
   leaves its image, near3[index] = where), the second's 2 * index + 1 (it
   reads it); ALONE = computed by each side, with no image (a ghost, or an
   atom not in the list).  The images themselves are appended as they are
   made, only for pairs within reach: a compact array, in cache when read.
------------------------------------------------------------------------- */

void PairMindlinSmooth::order_neighbors_3d()
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;

  // position of each owned atom in the list (-1: not in it)
  std::vector<int> rank(nlocal, -1);
  int total = 0;
  for (int ii = 0; ii < inum; ii++) {
    rank[ilist[ii]] = ii;
    total += numneigh[ilist[ii]];
  }
  first3.resize(inum + 1);
  twins3.resize(inum);
  entries3.resize(total);
  int most = 0, npair = 0, n = 0;
  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const int *jlist = firstneigh[i];
    first3[ii] = n;
    for (int jj = 0; jj < numneigh[i]; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      const int jr = (j < nlocal) ? rank[j] : -1;
      int img = ALONE;
      if (jr > ii)
        img = 2 * npair++;
      else if (jr >= 0 && jr < ii) {
        // the image j made for this pair: j's entry of i
        for (int e = first3[jr]; e < first3[jr + 1]; e++)
          if (entries3[e].j == i && entries3[e].img >= 0 && !(entries3[e].img & 1))
            img = entries3[e].img + 1;
        if (img == ALONE)
          error->one(FLERR,
                     "Pair style mindlin/smooth: atom {} is a neighbour of atom {} but not the "
                     "other way round (the neighbor list is not symmetric)",
                     tag[j], tag[i]);
      }
      // insertion in ascending partner tag
      int e = n++;
      while (e > first3[ii] && tag[entries3[e - 1].j] > tag[j]) {
        entries3[e] = entries3[e - 1];
        e--;
      }
      entries3[e] = {j, img};
    }
    most = MAX(most, n - first3[ii]);
    twins3[ii] = 0;
    for (int e = first3[ii] + 1; e < n; e++)
      if (tag[entries3[e].j] == tag[entries3[e - 1].j]) twins3[ii] = 1;
  }
  first3[inum] = n;
  near3.resize(npair);
  if ((int) images3.size() < npair) images3.resize(npair + npair / 8 + 1);
  if ((int) contacts3.size() < most) {
    contacts3.resize(most);
    pending3.resize(most);
  }

  ordered3_list = list;
  ordered3_inum = inum;
  ordered3_nlocal = nlocal;
}

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
  // (no rows at all before the first atom: nothing to read then)
  const bool rows = (atom->nmax > 0);
  const Atoms3 at = {rows ? x[0] : nullptr,
                     rows ? atom->v[0] : nullptr,
                     rows ? atom->omega[0] : nullptr,
                     radius, atom->type, update->dt, update_history != 0, evflag != 0};
  const double *xrow = at.x;
  const double tbase = touch_base(domain);
  int nslot = ncol;

  const int inum = list->inum;
  const int *ilist = list->ilist;
  // a list built this step (ago = 0: set by every build, in a run and in
  // its setup), or another list or atom count than the last one ordered
  if (neighbor->ago == 0 || list != ordered3_list || inum != ordered3_inum ||
      nlocal != ordered3_nlocal)
    order_neighbors_3d();
  const Entry3 *entries = entries3.data();
  const int *first = first3.data();
  Image3 *images = images3.data();
  int *near = near3.data();
  int nimage = 0;
  Contact3 *cs = contacts3.data();
  Pending3 *pend = pending3.data();

  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const tagint itag = tag[i];
    const double radi = radius[i];
    const double xi[3] = {x[i][0], x[i][1], x[i][2]};
    const int *ipartner = partner[i];
    const double *const itc[3] = {tc[0][i], tc[1][i], tc[2][i]};
    const int itype = at.type[i];
    const Own3 own = {at.v + 3 * (size_t) i, at.omega + 3 * (size_t) i, radi, kn[itype],
                      kt[itype], mu[itype]};
    int nc = 0;
    int walk = 0;       // walk_slot() along i's history row

    int np = 0;         // contacts to compute here (pend)

    // the contacts in ascending partner tag: computed here (with ghosts,
    // and with owned atoms later in the list, which get the image), or
    // the image of the side computed by an atom earlier in the list
    // (twins: a tag occurs twice among the neighbours, two periodic images
    // of one atom; then the contacts are checked for it after this loop)
    const bool twins = twins3[ii] != 0;
    const int elast = first[ii + 1];
    for (int e = first[ii]; e < elast; e++) {
      const int j = entries[e].j, img = entries[e].img;

      if (img & 1) {
        // the mirror image where i's own history is the image of j's,
        // else i's side anew
        const int m = near[img >> 1];
        if (m < 0) continue;
        const Image3 &im = images[m];
        const tagint jtag = tag[j];
        const bool band = (im.flags & IN_BAND) != 0;
        const int slot = walk_slot(ipartner, nslot, walk, jtag);
        double stored[3];
        stored_t(itc, slot, band, stored);
        const bool mirror = band ? (((im.flags & HAS_SLOT) != 0) == (slot >= 0))
                                 : (stored[0] == -im.stored[0] && stored[1] == -im.stored[1] &&
                                    stored[2] == -im.stored[2]);
        if (mirror) {
          if (!(im.flags & HAS_CONTACT)) continue;
          Contact3 &c = cs[nc++];
          c.tag = jtag;
          c.listed = (im.flags & LISTED) != 0;
          for (int k = 0; k < 3; k++) {
            c.t[k] = -im.t[k];
            c.f[k] = -im.f[k];
            c.nxf[k] = im.nxf[k];    // n x F_t: both factors change sign
          }
          if (evflag) {
            for (int k = 0; k < 3; k++) c.del[k] = xi[k] - xrow[3 * (size_t) j + k];
            c.en = im.en;
          }
          continue;
        }
        // the same geometry as j's (del negated exactly)
        const double *xj = xrow + 3 * (size_t) j;
        const double del[3] = {xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]};
        const double r = sqrt(MindlinSmooth::dot3(del, del));
        const double gap = (radi + radius[j]) - r;
        const bool listed = band ? (slot >= 0) : (gap > 0.0);
        if (!(listed || gap > 0.0)) continue;
        cs[nc].tag = jtag;
        pend[np++] = {j, nc++, ALONE, 0, {del[0], del[1], del[2]}, r, gap,
                      {stored[0], stored[1], stored[2]}, band, listed};
        continue;
      }

      const double *xj = xrow + 3 * (size_t) j;
      const double del[3] = {xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]};
      const double rsq = MindlinSmooth::dot3(del, del);
      const double radsum = radi + radius[j];
      const double tau = touch_band(tbase, radsum);
      const double rmax = radsum + tau;
      if (rsq >= rmax * rmax) {
        if (img >= 0) near[img >> 1] = -1;
        continue;
      }

      if (rsq == 0.0)
        error->one(FLERR,
                   "Pair style mindlin/smooth: atoms {} and {} have coincident centres "
                   "(no contact normal)",
                   itag, tag[j]);
      const tagint jtag = tag[j];
      const double r = sqrt(rsq);
      const double gap = radsum - r;
      const bool band = (gap <= tau && gap >= -tau);
      const int slot = walk_slot(ipartner, nslot, walk, jtag);
      double stored[3];
      stored_t(itc, slot, band, stored);
      const bool listed = band ? (slot >= 0) : (gap > 0.0);
      const bool has = listed || gap > 0.0;
      const int flags = (has ? HAS_CONTACT : 0) | (listed ? LISTED : 0) |
          (band ? IN_BAND : 0) | (slot >= 0 ? HAS_SLOT : 0);
      if (has) {
        cs[nc].tag = jtag;
        pend[np++] = {j, nc++, img, flags, {del[0], del[1], del[2]}, r, gap,
                      {stored[0], stored[1], stored[2]}, band, listed};
        continue;
      }
      if (img < 0) continue;
      near[img >> 1] = nimage;
      Image3 &im = images[nimage++];
      im.flags = flags;
      for (int k = 0; k < 3; k++) im.stored[k] = stored[k];
    }

    // The contacts computed here, after the loop over the neighbours: a
    // short loop of independent contacts, whose long chains of divisions
    // and square roots the processor can overlap
    for (int q = 0; q < np; q++) {
      const Pending3 &pc = pend[q];
      Contact3 &c = cs[pc.pos];
      contact_side(at, own, pc.j, pc.del, pc.r, pc.gap, pc.band, pc.stored, pc.listed, c);
      if (pc.img < 0) continue;
      near[pc.img >> 1] = nimage;
      Image3 &im = images[nimage++];
      im.flags = pc.flags;
      for (int k = 0; k < 3; k++) {
        im.stored[k] = pc.stored[k];
        im.t[k] = c.t[k];
        im.f[k] = c.f[k];
        im.nxf[k] = c.nxf[k];
      }
      if (evflag) im.en = c.en;
    }

    // a partner met twice (two periodic images), 0 if none: the first
    // contact whose partner is that of the one before
    tagint dup = 0;
    if (twins)
      for (int a = 1; a < nc && dup == 0; a++)
        if (cs[a].tag == cs[a - 1].tag) dup = cs[a].tag;

    if (nc > nslot && !history) too_many_contacts(itag);
    if (dup > 0) two_images(itag, dup);
    if (update_history && nc > nslot) {
      history->reserve(nc);
      find_history();
      partner = atom->iarray[idx_partner];
      for (int k = 0; k < 3; k++) tc[k] = atom->darray[idx_t3[k]];
      nslot = ncol;
    }

    // summed in registers: the same additions in the same order as into
    // f[i] and torque[i] directly, which the compiler would have to
    // reload after every store (they might alias the contacts); in the
    // same pass over the contacts, those kept in the history written to
    // i's row in ascending tag
    double fi[3] = {f[i][0], f[i][1], f[i][2]};
    double ti[3] = {torque[i][0], torque[i][1], torque[i][2]};
    int *prow = partner[i];
    double *const trow[3] = {tc[0][i], tc[1][i], tc[2][i]};
    int nl = 0;
    if (update_history)
      for (int a = 0; a < nc; a++) {
        const Contact3 &c = cs[a];
        for (int k = 0; k < 3; k++) {
          fi[k] += c.f[k];
          ti[k] += -radi * c.nxf[k];
        }
        if (!c.listed) continue;
        prow[nl] = c.tag;
        for (int k = 0; k < 3; k++) trow[k][nl] = c.t[k];
        nl++;
      }
    else
      for (int a = 0; a < nc; a++)
        for (int k = 0; k < 3; k++) {
          fi[k] += cs[a].f[k];
          ti[k] += -radi * cs[a].nxf[k];
        }

    for (int k = 0; k < 3; k++) {
      f[i][k] = fi[k];
      torque[i][k] = ti[k];
    }
    if (evflag)
      for (int a = 0; a < nc; a++) {
        const Contact3 &c = cs[a];
        ev_tally_xyz_full(i, c.en, 0.0, c.f[0], c.f[1], c.f[2], c.del[0], c.del[1], c.del[2]);
      }

    // the slots that held a contact and hold none now: slots are packed
    // and, once cleared whole (packed3), zero from the first empty one on,
    // so the old entries past nl end at the first zero
    if (update_history)
      for (int a = nl; a < nslot && (!packed3 || prow[a] != 0); a++) {
        prow[a] = 0;
        for (int k = 0; k < 3; k++) trow[k][a] = 0.0;
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
