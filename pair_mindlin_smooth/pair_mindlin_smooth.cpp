/* ----------------------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin)

   Each owned atom i loops over a FULL neighbor list and updates only its
   own side of each contact (the history slot matched by partner tag).
   The contacts of i are summed in ascending partner tag, so forces do not
   depend on neighbor-list order: runs with any number of MPI ranks and
   runs continued from data files are bitwise reproducible.

   The pair loops: pair_mindlin_smooth_2d.cpp (disks) and
   pair_mindlin_smooth_3d.cpp (spheres); here the settings, coefficients,
   cutoffs, the history's set-up, single(), restart and data output.
------------------------------------------------------------------------- */

#include "pair_mindlin_smooth.h"

#include "fix_mindlin_history.h"
#include "fix_mindlin_tags.h"
#include "mindlin_smooth_contacts.h"
#include "mindlin_smooth_kernel.h"
#include "mindlin_smooth_setup.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neighbor.h"
#include "update.h"

#include <cmath>
#include <cstring>
#include <unordered_set>
#include <vector>

using namespace LAMMPS_NS;
using MindlinSmooth::find_slot;
using MindlinSmooth::touch_band;
using MindlinSmooth::touch_base;

static const char *const HISTORY_PARTNER = FixMindlinHistory::PARTNER;
static const char *const HISTORY_T = FixMindlinHistory::T_2D;

/* ---------------------------------------------------------------------- */

PairMindlinSmooth::PairMindlinSmooth(LAMMPS *lmp) :
    Pair(lmp), kn(nullptr), kt(nullptr), mu(nullptr), maxrad(nullptr), ncol(0),
    idx_partner(-1), idx_t(-1), idx_t3{-1, -1, -1}, ordered3_list(nullptr),
    ordered3_inum(-1), ordered3_nlocal(-1), history(nullptr), tags(nullptr), packed3(false),
    check_rows(false)
{
  single_enable = 1;
  restartinfo = 1;
  writedata = 1;
  finitecutflag = 1;
  no_virial_fdotr_compute = 1;
  single_extra = 5;    // 7 in 3d (init_style)
  svector = new double[7];
}

/* ---------------------------------------------------------------------- */

PairMindlinSmooth::~PairMindlinSmooth()
{
  delete[] svector;
  if (history && modify->get_fix_by_id(FixMindlinHistory::ID))
    modify->delete_fix(FixMindlinHistory::ID);
  if (tags && modify->get_fix_by_id(FixMindlinTags::ID)) modify->delete_fix(FixMindlinTags::ID);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
    memory->destroy(kn);
    memory->destroy(kt);
    memory->destroy(mu);
    delete[] maxrad;
  }
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::allocate()
{
  allocated = 1;
  const int n = atom->ntypes + 1;
  memory->create(setflag, n, n, "pair:setflag");
  memory->create(cutsq, n, n, "pair:cutsq");
  memory->create(kn, n, n, "pair:kn");
  memory->create(kt, n, n, "pair:kt");
  memory->create(mu, n, n, "pair:mu");
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) {
      setflag[i][j] = 0;
      kn[i][j] = kt[i][j] = mu[i][j] = 0.0;
    }
  maxrad = new double[n];
  for (int i = 0; i < n; i++) maxrad[i] = 0.0;
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::settings(int narg, char **arg)
{
  if (narg != 0)
    error->all(FLERR, "Pair style mindlin/smooth takes no arguments, got '{}'", arg[0]);
}

/* ----------------------------------------------------------------------
   pair_coeff I J k_n k_t mu
------------------------------------------------------------------------- */

void PairMindlinSmooth::coeff(int narg, char **arg)
{
  MindlinSmooth::refuse_rolling_twisting(lmp, "Pair coeff mindlin/smooth", narg, arg);
  if (narg != 5)
    error->all(FLERR,
               "Pair coeff for mindlin/smooth needs 5 arguments (I J k_n k_t mu), got {}",
               narg);
  if (!allocated) allocate();

  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);

  const double kn_one = utils::numeric(FLERR, arg[2], false, lmp);
  const double kt_one = utils::numeric(FLERR, arg[3], false, lmp);
  const double mu_one = utils::numeric(FLERR, arg[4], false, lmp);

  if (!std::isfinite(kn_one) || kn_one <= 0.0)
    error->all(FLERR, "Pair coeff mindlin/smooth: k_n must be > 0, got {}", arg[2]);
  if (!std::isfinite(kt_one) || kt_one < 0.0)
    error->all(FLERR, "Pair coeff mindlin/smooth: k_t must be >= 0, got {}", arg[3]);
  if (!std::isfinite(mu_one) || mu_one < 0.0)
    error->all(FLERR, "Pair coeff mindlin/smooth: mu must be >= 0, got {}", arg[4]);

  int count = 0;
  for (int i = ilo; i <= ihi; i++) {
    for (int j = MAX(jlo, i); j <= jhi; j++) {
      kn[i][j] = kn_one;
      kt[i][j] = kt_one;
      mu[i][j] = mu_one;
      setflag[i][j] = 1;
      count++;
    }
  }
  if (count == 0)
    error->all(FLERR, "Pair coeff mindlin/smooth: no type pairs in '{} {}'", arg[0], arg[1]);
}

/* ----------------------------------------------------------------------
   the history arrays: the internal fix's, or those of a fix property/atom
   the deck defined before the atoms (older decks; history in data files)
------------------------------------------------------------------------- */

void PairMindlinSmooth::setup_history()
{
  history = dynamic_cast<FixMindlinHistory *>(modify->get_fix_by_id(FixMindlinHistory::ID));
  int flag, cols;
  const char *tname = (domain->dimension == 3) ? FixMindlinHistory::T_3D[0] : HISTORY_T;
  if (!history && atom->find_custom(HISTORY_PARTNER, flag, cols) < 0 &&
      atom->find_custom(tname, flag, cols) < 0)
    history = dynamic_cast<FixMindlinHistory *>(
        modify->add_fix(fmt::format("{} all mindlin/history", FixMindlinHistory::ID)));
  find_history();

  // the history names partners by atom ID: after delete_atoms or
  // reset_atoms gave new IDs, it is made to follow them (fix_mindlin_tags.cpp)
  tags = dynamic_cast<FixMindlinTags *>(modify->get_fix_by_id(FixMindlinTags::ID));
  if (!tags)
    tags = dynamic_cast<FixMindlinTags *>(
        modify->add_fix(fmt::format("{} all mindlin/tags", FixMindlinTags::ID)));
  double **t[3] = {nullptr, nullptr, nullptr};
  const int nt = (domain->dimension == 3) ? 3 : 1;
  for (int c = 0; c < nt; c++) t[c] = atom->darray[(nt == 3) ? idx_t3[c] : idx_t];
  check_rows = tags->follow_new_ids(atom->iarray[idx_partner], t, nt, ncol);
}

/* ----------------------------------------------------------------------
   A history that no record follows (read from a data file, or set by a
   driver, since the last run) names partners by the IDs it was written
   with.  If delete_atoms (compress yes), reset_atoms id or replicate gave
   atoms other IDs in between, its entries name other atoms, mostly far
   away: the first run would drop those contacts' tangential displacement,
   or give it to the wrong pair, silently.  At that run's setup (ghosts and
   neighbour list built) every entry is looked up among its atom's
   neighbours; the entries naming an atom that exists but is not among
   them (farther than the neighbour cutoff, skin included) are counted,
   and a warning says how many.  A contact that opened by a small move
   (a driver's Newton step before its first run) keeps its partner in the
   list and is not counted.  (A partner deleted with compress no names no
   atom and is dropped, as always, without warning.  An entry renamed onto
   a neighbour is not seen.)
------------------------------------------------------------------------- */

void PairMindlinSmooth::setup()
{
  if (!check_rows) return;
  check_rows = false;
  find_history();
  int **partner = atom->iarray[idx_partner];
  const tagint *tag = atom->tag;

  // entries whose partner is not among the atom's neighbours
  std::vector<tagint> away;
  for (int ii = 0; ii < list->inum; ii++) {
    const int i = list->ilist[ii];
    const int *jlist = list->firstneigh[i];
    const int jnum = list->numneigh[i];
    for (int k = 0; k < ncol; k++) {
      const tagint p = partner[i][k];
      if (p == 0) continue;
      bool listed = false;
      for (int jj = 0; jj < jnum && !listed; jj++) listed = (tag[jlist[jj] & NEIGHMASK] == p);
      if (!listed) away.push_back(p);
    }
  }

  // of those, the ones that name an atom that exists (on any rank)
  const std::vector<tagint> all = tags->everyones(away);
  if (all.empty()) return;
  std::unordered_set<tagint> owned(tag, tag + atom->nlocal);
  bigint mine = 0, existing = 0;
  for (tagint p : all)
    if (owned.count(p)) mine++;
  MPI_Allreduce(&mine, &existing, 1, MPI_LMP_BIGINT, MPI_SUM, world);
  if (existing > 0 && comm->me == 0)
    error->warning(FLERR,
                   "Pair style mindlin/smooth: {} contact-history entries name an atom that "
                   "exists but is not a neighbour; their tangential displacement is dropped. "
                   "Were atom IDs changed after the history was read (delete_atoms with "
                   "compress yes, reset_atoms id, replicate)? Before the first run that is "
                   "not followed: delete with compress no, or after a run",
                   existing);
}

void PairMindlinSmooth::find_history()
{
  int flag, cols;
  idx_partner = atom->find_custom(HISTORY_PARTNER, flag, cols);
  if ((idx_partner < 0 || flag != 0 || cols < 1) && domain->dimension == 3)
    error->all(FLERR,
               "Pair style mindlin/smooth: a fix property/atom defines d2_{} but not i2_{}; "
               "define i2_{} with d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz, or none of them",
               FixMindlinHistory::T_3D[0], HISTORY_PARTNER, HISTORY_PARTNER);
  if (idx_partner < 0 || flag != 0 || cols < 1)
    error->all(FLERR,
               "Pair style mindlin/smooth: a fix property/atom defines d2_{} but not i2_{}; "
               "define both ('fix ID all property/atom i2_{} 8 d2_{} 8 d_mindlin_wall_t "
               "ghost no') or neither",
               HISTORY_T, HISTORY_PARTNER, HISTORY_PARTNER, HISTORY_T);
  ncol = cols;
  int flag_t, cols_t;
  if (domain->dimension == 3) {
    // the three components of t, one array each
    for (int c = 0; c < 3; c++) {
      const char *name = FixMindlinHistory::T_3D[c];
      idx_t3[c] = atom->find_custom(name, flag_t, cols_t);
      if (idx_t3[c] < 0 || flag_t != 1 || cols_t != ncol)
        error->all(FLERR,
                   "Pair style mindlin/smooth: in 3d the history needs per-atom arrays "
                   "d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz with as many columns as "
                   "i2_{} ({}); d2_{} is {}",
                   HISTORY_PARTNER, ncol, name,
                   (idx_t3[c] < 0) ? std::string("missing")
                                   : fmt::format("of {} columns", cols_t));
    }
    return;
  }
  idx_t = atom->find_custom(HISTORY_T, flag_t, cols_t);
  if (idx_t < 0 || flag_t != 1 || cols_t != ncol)
    error->all(FLERR,
               "Pair style mindlin/smooth: per-atom array d2_{} must exist with as "
               "many columns as i2_{} ({})",
               HISTORY_T, HISTORY_PARTNER, ncol);
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::init_style()
{
  MindlinSmooth::require_spheres(lmp, "Pair style mindlin/smooth");
  MindlinSmooth::require_atom_ids(lmp, "Pair style mindlin/smooth");
  // a special_bonds weight strictly between 0 and 1 keeps the pair in the list
  // with a factor this style does not apply (0 removes it, 1 is the full force)
  for (int k = 1; k <= 3; k++)
    if (force->special_lj[k] != 0.0 && force->special_lj[k] != 1.0)
      error->all(FLERR,
                 "Pair style mindlin/smooth does not scale contact forces by special_bonds "
                 "weights: lj weight {} of 1-{} neighbors must be 0 (no contact) or 1 "
                 "(full contact)",
                 force->special_lj[k], k + 1);
  bool frictionless = true;    // every pair_coeff without tangential force (mixing keeps it)
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++)
      if (setflag[i][j] && mu[i][j] * kt[i][j] != 0.0) frictionless = false;
  MindlinSmooth::forbid_minimize(lmp, "Pair style mindlin/smooth", frictionless);
  if (comm->ghost_velocity == 0)
    error->all(FLERR,
               "Pair style mindlin/smooth requires ghost atoms store velocity: "
               "use 'comm_modify vel yes'");

  single_extra = (domain->dimension == 3) ? 7 : 5;
  packed3 = false;    // the history may have been read or set: clear it whole once
  ordered3_list = nullptr;    // the atoms may have been sorted or replaced
  setup_history();
  if ((int) contacts.size() < ncol) contacts.resize(ncol);

  // Full list with per-type cutoffs (largest radii of the two types): a
  // size-based full list would stop compute pair/local from deriving its
  // half list from ours (LAMMPS has no halffull/size list builder).
  neighbor->add_request(this, NeighConst::REQ_FULL);

  // largest radius per atom type sets the neighbor cutoff

  const int ntypes = atom->ntypes;
  std::vector<double> local(ntypes + 1, 0.0);
  const double *radius = atom->radius;
  const int *type = atom->type;
  for (int i = 0; i < atom->nlocal; i++) local[type[i]] = MAX(local[type[i]], radius[i]);
  MPI_Allreduce(local.data(), maxrad, ntypes + 1, MPI_DOUBLE, MPI_MAX, world);
  insertion_radii();

  double largest = 0.0;
  for (int i = 1; i <= ntypes; i++) largest = MAX(largest, maxrad[i]);
  if (!(largest > 0.0))
    error->all(FLERR,
               "Pair style mindlin/smooth: no disk has a radius > 0 and no fix pour or fix "
               "deposit will insert any, so the neighbor cutoff would be 0");
}

/* ----------------------------------------------------------------------
   disks that fix pour / fix deposit will insert during the run count in
   the cutoff of their type (these fixes answer extract("radius", type))
------------------------------------------------------------------------- */

void PairMindlinSmooth::insertion_radii()
{
  for (const char *style : {"^pour", "^deposit"})
    for (auto *ifix : modify->get_fix_by_style(style))
      for (int i = 1; i <= atom->ntypes; i++) {
        int itype = i;
        auto *rad = static_cast<double *>(ifix->extract("radius", itype));
        if (rad && *rad > maxrad[i]) maxrad[i] = *rad;
      }
}

/* ---------------------------------------------------------------------- */

double PairMindlinSmooth::init_one(int i, int j)
{
  if (setflag[i][j] == 0) {
    if (setflag[i][i] == 0 || setflag[j][j] == 0)
      error->all(FLERR, "Pair style mindlin/smooth: coefficients for types {} {} are not set",
                 i, j);
    // geometric mixing, as pair granular does
    kn[i][j] = sqrt(kn[i][i] * kn[j][j]);
    kt[i][j] = sqrt(kt[i][i] * kt[j][j]);
    mu[i][j] = sqrt(mu[i][i] * mu[j][j]);
  }
  kn[j][i] = kn[i][j];
  kt[j][i] = kt[i][j];
  mu[j][i] = mu[i][j];
  if (!std::isfinite(mu[i][j]) || mu[i][j] < 0.0)
    error->all(FLERR, "Pair style mindlin/smooth: mu for types {} {} must be >= 0, got {}", i, j,
               mu[i][j]);
  return maxrad[i] + maxrad[j];
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  if (domain->dimension == 3)
    compute_3d();
  else
    compute_2d();
}

/* ----------------------------------------------------------------------
   scratch space for an atom with n neighbours (at most n contacts); the
   internal history grows to match before it is written
------------------------------------------------------------------------- */

int PairMindlinSmooth::grow_scratch(int n)
{
  contacts.resize(MAX((size_t) n, 2 * contacts.size()));
  return (int) contacts.size();
}

/* ----------------------------------------------------------------------
   atom with tag itag has more contacts than the columns of the fix
   property/atom that holds the history
------------------------------------------------------------------------- */

void PairMindlinSmooth::too_many_contacts(tagint itag)
{
  // the arrays of t by dimension: d2_mindlin_t, or d2_mindlin_tx, _ty, _tz
  const std::string ts = (domain->dimension == 3)
      ? fmt::format("d2_{}, d2_{} and d2_{}", FixMindlinHistory::T_3D[0],
                    FixMindlinHistory::T_3D[1], FixMindlinHistory::T_3D[2])
      : fmt::format("d2_{}", HISTORY_T);
  error->one(FLERR,
             "Pair style mindlin/smooth: atom {} has more than {} contacts; give i2_{} and "
             "{} more columns, or drop the fix property/atom that defines them so that "
             "the pair keeps the history itself with no limit",
             itag, ncol, HISTORY_PARTNER, ts);
}

/* ----------------------------------------------------------------------
   atom itag touches two periodic images of atom jtag
------------------------------------------------------------------------- */

void PairMindlinSmooth::two_images(tagint itag, tagint jtag)
{
  error->one(FLERR,
             "Pair style mindlin/smooth: atom {} touches two periodic images of atom {}; the "
             "box is too small",
             itag, jtag);
}

/* ----------------------------------------------------------------------
   force of one pair from the stored history; never changes state.
   fforce: normal force / r along x_i - x_j.
   svector: F_t,x  F_t,y  u = |t|/t*  t_x  t_y  (tangential part, on atom i)
   and in 3d F_t,z  t_z
------------------------------------------------------------------------- */

double PairMindlinSmooth::single(int i, int j, int itype, int jtype, double rsq,
                                 double /*factor_coul*/, double /*factor_lj*/, double &fforce)
{
  // the force of a contact depends on the two atoms (radii, history), not on
  // their types: single() of atoms i and j at their distance (compute
  // pair/local) works, pair_write (atoms 0 and 1 at any rsq) does not
  const int nall = atom->nlocal + atom->nghost;
  if (i < 0 || j < 0 || i >= nall || j >= nall)
    error->one(FLERR,
               "Pair style mindlin/smooth: single() of atoms {} and {} of {}: pair_write is "
               "not supported (a contact depends on the radii and history of two atoms, not "
               "on their types)",
               i, j, nall);
  {
    double **x = atom->x;
    const double dx = x[i][0] - x[j][0], dy = x[i][1] - x[j][1], dz = x[i][2] - x[j][2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (!(fabs(d2 - rsq) <= 1e-10 * MAX(d2, rsq)))
      error->one(FLERR,
                 "Pair style mindlin/smooth: single() got rsq = {} for atoms {} and {} at "
                 "squared distance {}: pair_write is not supported (a contact depends on the "
                 "radii and history of two atoms, not on their types)",
                 rsq, atom->tag[i], atom->tag[j], d2);
  }
  if (domain->dimension == 3) return single_3d(i, j, itype, jtype, rsq, fforce);
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  fforce = 0.0;
  const double radsum = atom->radius[i] + atom->radius[j];
  const double tau = touch_band(touch_base(domain), radsum);
  const double rmax = radsum + tau;
  if (rsq >= rmax * rmax || rsq == 0.0) return 0.0;    // compute() rejects rsq == 0

  if (idx_t < 0) find_history();
  const int slot = find_slot(atom->iarray[idx_partner][i], atom->icols[idx_partner], atom->tag[j]);
  const double r = sqrt(rsq);
  const double gap = radsum - r;
  if (!(gap > 0.0)) return 0.0;    // as compute(): no force
  const double xi = (slot >= 0 && gap > tau) ? atom->darray[idx_t][i][slot] : 0.0;

  double **x = atom->x;
  const double delx = x[i][0] - x[j][0];
  const double dely = x[i][1] - x[j][1];
  const double nx = delx / r, ny = dely / r;
  const double delta = gap;
  const MindlinSmooth::Params p = {kn[itype][jtype], kt[itype][jtype], mu[itype][jtype]};
  const MindlinSmooth::Response res = MindlinSmooth::evaluate(p, delta, xi);

  fforce = res.fn / r;
  svector[0] = res.ft * ny;
  svector[1] = -res.ft * nx;
  svector[2] = res.u;
  svector[3] = res.xi * ny;
  svector[4] = -res.xi * nx;
  return 0.4 * res.fn * delta;
}

/* ---------------------------------------------------------------------- */

void *PairMindlinSmooth::extract(const char *str, int &dim)
{
  dim = 2;
  if (strcmp(str, "k_n") == 0) return (void *) kn;
  if (strcmp(str, "k_t") == 0) return (void *) kt;
  if (strcmp(str, "mu") == 0) return (void *) mu;
  return nullptr;
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::write_restart(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      fwrite(&setflag[i][j], sizeof(int), 1, fp);
      if (setflag[i][j]) {
        fwrite(&kn[i][j], sizeof(double), 1, fp);
        fwrite(&kt[i][j], sizeof(double), 1, fp);
        fwrite(&mu[i][j], sizeof(double), 1, fp);
      }
    }
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::read_restart(FILE *fp)
{
  allocate();
  const int me = comm->me;
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      if (me == 0) utils::sfread(FLERR, &setflag[i][j], sizeof(int), 1, fp, nullptr, error);
      MPI_Bcast(&setflag[i][j], 1, MPI_INT, 0, world);
      if (setflag[i][j]) {
        double buf[3];
        if (me == 0) utils::sfread(FLERR, buf, sizeof(double), 3, fp, nullptr, error);
        MPI_Bcast(buf, 3, MPI_DOUBLE, 0, world);
        kn[i][j] = buf[0];
        kt[i][j] = buf[1];
        mu[i][j] = buf[2];
      }
    }
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::write_data(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    fprintf(fp, "%d %.17g %.17g %.17g\n", i, kn[i][i], kt[i][i], mu[i][i]);
}

/* ---------------------------------------------------------------------- */

void PairMindlinSmooth::write_data_all(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++)
      fprintf(fp, "%d %d %.17g %.17g %.17g\n", i, j, kn[i][j], kt[i][j], mu[i][j]);
}
