/* ----------------------------------------------------------------------
   remote-trigger: fix addforce/oscillating (LAMMPS plugin)

   The force is added in post_force, after the pair and the fixes defined
   before this one, as fix addforce does; the sum Fx + f(t) is formed once
   per step with the arithmetic of the equal-style expression
   Fx + a*e*cos(omega*time), e = 0.5*(1.0 - cos(PI*time/T)), so a deck
   that used per-atom variables for this load gets the same bits.
------------------------------------------------------------------------- */

#include "fix_addforce_oscillating.h"
#include "mindlin_smooth_setup.h"

#include "atom.h"
#include "error.h"
#include "update.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

static const char USAGE[] = "fix ID group addforce/oscillating Fx Fy Fz a omega [onset T]";

/* ---------------------------------------------------------------------- */

FixAddForceOscillating::FixAddForceOscillating(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), onset(0.0)
{
  if (narg != 8 && narg != 10)
    error->all(FLERR, "Fix addforce/oscillating needs 5 values and an optional 'onset T', "
                      "got {} arguments; use {}", narg - 3, USAGE);
  fx = number(arg[3], "Fx");
  fy = number(arg[4], "Fy");
  fz = number(arg[5], "Fz");
  amp = number(arg[6], "a");
  omega = number(arg[7], "omega");
  if (narg == 10) {
    if (strcmp(arg[8], "onset") != 0)
      error->all(FLERR, "Fix addforce/oscillating: unknown keyword '{}'; use {}", arg[8],
                 USAGE);
    onset = number(arg[9], "onset T");
    if (onset < 0.0)
      error->all(FLERR, "Fix addforce/oscillating: onset T must be >= 0, got {}", arg[9]);
  }

  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extvector = 0;
}

/* ---------------------------------------------------------------------- */

double FixAddForceOscillating::number(const char *str, const char *what)
{
  const double val = utils::numeric(FLERR, str, false, lmp);
  if (!std::isfinite(val))
    error->all(FLERR, "Fix addforce/oscillating: {} must be a finite number, got {}", what,
               str);
  return val;
}

/* ---------------------------------------------------------------------- */

int FixAddForceOscillating::setmask()
{
  return POST_FORCE;
}

/* ---------------------------------------------------------------------- */

void FixAddForceOscillating::init()
{
  MindlinSmooth::forbid_respa(lmp, "Fix addforce/oscillating");
}

/* ---------------------------------------------------------------------- */

void FixAddForceOscillating::setup(int vflag)
{
  post_force(vflag);
}

/* ----------------------------------------------------------------------
   simulation time of the current step, as thermo keyword 'time'
------------------------------------------------------------------------- */

double FixAddForceOscillating::now() const
{
  return update->atime + (update->ntimestep - update->atimestep) * update->dt;
}

/* ----------------------------------------------------------------------
   f(t) and the envelope e(t)
------------------------------------------------------------------------- */

double FixAddForceOscillating::forcing(double t, double &env) const
{
  env = (t < onset) ? 0.5 * (1.0 - cos(M_PI * t / onset)) : 1.0;
  return amp * env * cos(omega * t);
}

/* ---------------------------------------------------------------------- */

void FixAddForceOscillating::post_force(int /*vflag*/)
{
  double env;
  const double fxt = (amp == 0.0) ? fx : fx + forcing(now(), env);

  double **f = atom->f;
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;
  for (int i = 0; i < nlocal; i++)
    if (mask[i] & groupbit) {
      f[i][0] += fxt;
      f[i][1] += fy;
      f[i][2] += fz;
    }
}

/* ----------------------------------------------------------------------
   0 = f(t), 1 = e(t) at the current step
------------------------------------------------------------------------- */

double FixAddForceOscillating::compute_vector(int n)
{
  double env;
  const double ft = forcing(now(), env);
  return (n == 0) ? ft : env;
}
