/* ----------------------------------------------------------------------
   remote-trigger: fix mu/velocity (LAMMPS plugin)

   The coefficient is set in pre_force (and setup_pre_force), after the
   first half of the velocity-Verlet step: the force computation of a step
   sees mu of the half-step velocities, the value an equal-style variable
   with vcm(group,x) gives when fix adapt (pre_force) and a wall with
   v_name (post_force) evaluate it.  The mean velocity is computed with
   the arithmetic of vcm(): sum of m v_x over the group, divided by the
   sum of m, so both routes give the same bits.
------------------------------------------------------------------------- */

#include "fix_mu_velocity.h"
#include "mindlin_smooth_setup.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "group.h"
#include "modify.h"
#include "pair.h"
#include "update.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

static const char USAGE[] =
    "fix ID group mu/velocity mu0 v0 B w mu_ss [vss V] [pair yes|no] [wall yes|no]";

/* ---------------------------------------------------------------------- */

FixMuVelocity::FixMuVelocity(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), pairflag(1), wallflag(1), vcm(0.0), vmax(0.0), tswitch(-1.0),
    pair_mu(nullptr), warned(false)
{
  if (narg < 8) error->all(FLERR, "Fix mu/velocity needs 5 values: {}", USAGE);

  mu0 = positive_arg(arg[3], "mu0", false);
  v0 = positive_arg(arg[4], "v0", false);
  B = positive_arg(arg[5], "B", false);
  w = positive_arg(arg[6], "w", false);
  muss = positive_arg(arg[7], "mu_ss", false);
  if (muss > 1.0)
    error->all(FLERR, "Fix mu/velocity: mu_ss must be <= 1 (a fraction of mu0), got {}",
               arg[7]);
  vss = v0;

  int iarg = 8;
  while (iarg < narg) {
    if (iarg + 1 >= narg)
      error->all(FLERR, "Fix mu/velocity: keyword {} needs a value; use {}", arg[iarg], USAGE);
    if (strcmp(arg[iarg], "vss") == 0) {
      vss = positive_arg(arg[iarg + 1], "vss", true);
    } else if (strcmp(arg[iarg], "pair") == 0) {
      pairflag = utils::logical(FLERR, arg[iarg + 1], false, lmp);
    } else if (strcmp(arg[iarg], "wall") == 0) {
      wallflag = utils::logical(FLERR, arg[iarg + 1], false, lmp);
    } else {
      error->all(FLERR, "Fix mu/velocity: unknown keyword '{}'; use {}", arg[iarg], USAGE);
    }
    iarg += 2;
  }
  if (!(vss > 0.0))
    error->all(FLERR,
               "Fix mu/velocity: vss must be > 0, got {} (vss defaults to v0; give 'vss V' "
               "when v0 = 0)",
               vss);

  mu = mu0;
  vector_flag = 1;
  size_vector = 4;
  global_freq = 1;
  extvector = 0;
  restart_global = 1;
}

/* ----------------------------------------------------------------------
   a finite number >= 0 (> 0 if strict), else an error naming it
------------------------------------------------------------------------- */

double FixMuVelocity::positive_arg(const char *str, const char *what, bool strict)
{
  const double val = utils::numeric(FLERR, str, false, lmp);
  if (!std::isfinite(val) || val < 0.0 || (strict && val == 0.0))
    error->all(FLERR, "Fix mu/velocity: {} must be {} 0, got {}", what, strict ? ">" : ">=",
               str);
  return val;
}

/* ---------------------------------------------------------------------- */

int FixMuVelocity::setmask()
{
  return PRE_FORCE;
}

/* ----------------------------------------------------------------------
   the coefficients this fix sets: mu[i][j] of pair mindlin/smooth and mu
   of every fix wall/mindlin/smooth
------------------------------------------------------------------------- */

void FixMuVelocity::init()
{
  MindlinSmooth::forbid_respa(lmp, "Fix mu/velocity");
  pair_mu = nullptr;
  if (pairflag) {
    Pair *pair = force->pair_match("mindlin/smooth", 1);
    if (!pair)
      error->all(FLERR, "Fix mu/velocity {}: no pair style mindlin/smooth to set mu of; "
                        "define it or use 'pair no'", id);
    int dim = -1;
    pair_mu = static_cast<double **>(pair->extract("mu", dim));
    if (!pair_mu || dim != 2)
      error->all(FLERR, "Fix mu/velocity {}: pair style mindlin/smooth gives no mu array", id);
  }

  wall_mu.clear();
  if (wallflag) {
    for (auto *ifix : modify->get_fix_by_style("^wall/mindlin/smooth$")) {
      int dim = -1;
      auto *ptr = static_cast<double *>(ifix->extract("mu", dim));
      if (!ptr || dim != 0)
        error->all(FLERR,
                   "Fix mu/velocity {}: fix {} (wall/mindlin/smooth) takes mu from a "
                   "variable; give it a number, or use 'wall no'",
                   id, ifix->id);
      wall_mu.push_back(ptr);
    }
    if (wall_mu.empty())
      error->all(FLERR, "Fix mu/velocity {}: no fix wall/mindlin/smooth to set mu of; "
                        "define one or use 'wall no'", id);
  }
  if (!warned) warn_other_setters();
}

/* ----------------------------------------------------------------------
   another fix that may set the same mu (once per fix, at its first run):
   fix adapt (it may adapt mu of the pair) or a second fix mu/velocity.
   Both act in pre_force, so the later one in the fix list sets the mu the
   forces use, and the other's value is lost without an error.
------------------------------------------------------------------------- */

void FixMuVelocity::warn_other_setters()
{
  warned = true;
  if (comm->me != 0) return;
  if (pairflag)
    for (auto *ifix : modify->get_fix_by_style("^adapt"))
      error->warning(FLERR,
                     "Fix mu/velocity {}: fix {} ({}) is defined too; if it sets mu of "
                     "pair mindlin/smooth, the later of the two fixes sets mu every step "
                     "and the other's mu is lost",
                     id, ifix->id, ifix->style);
  for (auto *ifix : modify->get_fix_by_style("^mu/velocity$"))
    if (ifix != this && ((pairflag && static_cast<FixMuVelocity *>(ifix)->pairflag) ||
                         (wallflag && static_cast<FixMuVelocity *>(ifix)->wallflag)))
      error->warning(FLERR,
                     "Fix mu/velocity {}: fix {} (mu/velocity) sets mu too; the later of "
                     "the two fixes sets mu every step and the other's mu is lost",
                     id, ifix->id);
}

/* ---------------------------------------------------------------------- */

void FixMuVelocity::setup_pre_force(int /*vflag*/)
{
  update_mu();
}

void FixMuVelocity::pre_force(int /*vflag*/)
{
  update_mu();
}

/* ----------------------------------------------------------------------
   mean x-velocity of the group (one reduction), mu of Eq. 4, set in the
   pair and the walls
------------------------------------------------------------------------- */

void FixMuVelocity::update_mu()
{
  double **v = atom->v;
  const int *mask = atom->mask;
  const int *type = atom->type;
  const double *rmass = atom->rmass;
  const double *mass = atom->mass;
  const int nlocal = atom->nlocal;

  double local[2] = {0.0, 0.0}, total[2];
  for (int i = 0; i < nlocal; i++)
    if (mask[i] & groupbit) {
      const double m = rmass ? rmass[i] : mass[type[i]];
      local[0] += v[i][0] * m;
      local[1] += m;
    }
  MPI_Allreduce(local, total, 2, MPI_DOUBLE, MPI_SUM, world);
  vcm = (total[1] > 0.0) ? total[0] / total[1] : 0.0;
  if (!std::isfinite(vcm))
    error->all(FLERR, "Fix mu/velocity {}: the mean x-velocity of group {} is {} at step {}",
               id, group->names[igroup], vcm, update->ntimestep);

  const double vt = fabs(vcm) / vss;
  const double vt0 = v0 / vss;
  if (vt <= vt0) {
    mu = mu0;
  } else {
    mu = mu0 * (B * exp(-w * (vt - vt0)) + muss);
    if (tswitch < 0.0)
      tswitch = update->atime + (update->ntimestep - update->atimestep) * update->dt;
  }
  if (fabs(vcm) > vmax) vmax = fabs(vcm);

  if (pair_mu) {
    const int ntypes = atom->ntypes;
    for (int i = 1; i <= ntypes; i++)
      for (int j = 1; j <= ntypes; j++) pair_mu[i][j] = mu;
  }
  for (double *ptr : wall_mu) *ptr = mu;
}

/* ----------------------------------------------------------------------
   0 = mu, 1 = mean x-velocity of the group, 2 = largest |v| so far,
   3 = time of the first step with |v| > v0 (-1: none yet)
------------------------------------------------------------------------- */

double FixMuVelocity::compute_vector(int n)
{
  if (n == 0) return mu;
  if (n == 1) return vcm;
  if (n == 2) return vmax;
  return tswitch;
}

/* ----------------------------------------------------------------------
   restart: the running values (mu and v are recomputed at the next setup)
------------------------------------------------------------------------- */

void FixMuVelocity::write_restart(FILE *fp)
{
  if (comm->me == 0) {
    const double list[4] = {mu, vcm, vmax, tswitch};
    const int size = sizeof(list);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(list, sizeof(double), 4, fp);
  }
}

void FixMuVelocity::restart(char *buf)
{
  double list[4];
  memcpy(list, buf, sizeof(list));
  mu = list[0];
  vcm = list[1];
  vmax = list[2];
  tswitch = list[3];
}
