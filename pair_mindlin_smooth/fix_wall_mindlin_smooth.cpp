/* ----------------------------------------------------------------------
   remote-trigger: fix wall/mindlin/smooth (LAMMPS plugin)
------------------------------------------------------------------------- */

#include "fix_wall_mindlin_smooth.h"

#include "mindlin_smooth_kernel.h"
#include "mindlin_smooth_setup.h"

#include "atom.h"
#include "error.h"
#include "input.h"
#include "memory.h"
#include "update.h"
#include "variable.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

static const char HISTORY_WALL[] = "mindlin_wall_t";
static constexpr int NCOLS = 5;    // fx fy u t delta

/* ---------------------------------------------------------------------- */

FixWallMindlinSmooth::FixWallMindlinSmooth(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), mu_ivar(-1), idx_t(-1), nmax(0), reduced(0)
{
  if (narg != 8)
    error->all(FLERR,
               "Fix wall/mindlin/smooth needs: fix ID group wall/mindlin/smooth k_n k_t mu "
               "yplane y_lo (got {} arguments after the style)",
               narg - 3);

  kn = utils::numeric(FLERR, arg[3], false, lmp);
  kt = utils::numeric(FLERR, arg[4], false, lmp);
  if (!std::isfinite(kn) || kn <= 0.0)
    error->all(FLERR, "Fix wall/mindlin/smooth: k_n must be > 0, got {}", arg[3]);
  if (!std::isfinite(kt) || kt < 0.0)
    error->all(FLERR, "Fix wall/mindlin/smooth: k_t must be >= 0, got {}", arg[4]);

  mu = 0.0;
  if (utils::strmatch(arg[5], "^v_")) {
    mu_var = arg[5] + 2;
  } else {
    mu = utils::numeric(FLERR, arg[5], false, lmp);
    if (!std::isfinite(mu) || mu < 0.0)
      error->all(FLERR, "Fix wall/mindlin/smooth: mu must be >= 0, got {}", arg[5]);
  }

  if (strcmp(arg[6], "yplane") != 0)
    error->all(FLERR, "Fix wall/mindlin/smooth supports only 'yplane y_lo', got '{}'", arg[6]);
  ylo = utils::numeric(FLERR, arg[7], false, lmp);

  scalar_flag = 1;
  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extscalar = 1;
  extvector = 1;
  energy_global_flag = 1;
  peratom_flag = 1;
  size_peratom_cols = NCOLS;
  peratom_freq = 1;
  array_atom = nullptr;
  for (int k = 0; k < 3; k++) local[k] = total[k] = 0.0;
}

/* ---------------------------------------------------------------------- */

FixWallMindlinSmooth::~FixWallMindlinSmooth()
{
  memory->destroy(array_atom);
}

/* ---------------------------------------------------------------------- */

int FixWallMindlinSmooth::setmask()
{
  return POST_FORCE;
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::find_history()
{
  int flag, cols;
  idx_t = atom->find_custom(HISTORY_WALL, flag, cols);
  if (idx_t < 0 || flag != 1 || cols != 0)
    error->all(FLERR,
               "Fix wall/mindlin/smooth needs the wall history vector; add 'd_{}' to the "
               "fix property/atom that holds the contact history, before "
               "read_data/create_atoms",
               HISTORY_WALL);
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::init()
{
  MindlinSmooth::require_2d_spheres(lmp, "Fix wall/mindlin/smooth");
  MindlinSmooth::forbid_minimize(lmp, "Fix wall/mindlin/smooth");
  find_history();
  if (!mu_var.empty()) {
    mu_ivar = input->variable->find(mu_var.c_str());
    if (mu_ivar < 0)
      error->all(FLERR, "Fix wall/mindlin/smooth: variable {} for mu does not exist", mu_var);
    if (!input->variable->equalstyle(mu_ivar))
      error->all(FLERR, "Fix wall/mindlin/smooth: variable {} for mu is not equal-style",
                 mu_var);
  }
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::setup(int vflag)
{
  post_force(vflag);
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::post_force(int /*vflag*/)
{
  if (mu_ivar >= 0) {
    mu = input->variable->compute_equal(mu_ivar);
    if (!std::isfinite(mu) || mu < 0.0)
      error->all(FLERR, "Fix wall/mindlin/smooth: variable {} gave mu = {}, must be >= 0",
                 mu_var, mu);
  }

  if (atom->nmax > nmax) {
    memory->destroy(array_atom);
    nmax = atom->nmax;
    memory->create(array_atom, nmax, NCOLS, "wall/mindlin/smooth:array_atom");
  }

  find_history();
  double *tw = atom->dvector[idx_t];
  double **x = atom->x;
  double **v = atom->v;
  double **f = atom->f;
  double **omega = atom->omega;
  double **torque = atom->torque;
  const double *radius = atom->radius;
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;
  const int update_history = (update->setupflag == 0);
  const double dt = update->dt;
  const MindlinSmooth::Params p = {kn, kt, mu};

  for (int k = 0; k < 3; k++) local[k] = 0.0;
  reduced = 0;

  for (int i = 0; i < nlocal; i++) {
    double *out = array_atom[i];
    for (int k = 0; k < NCOLS; k++) out[k] = 0.0;
    if (!(mask[i] & groupbit)) continue;
    const double delta = radius[i] - (x[i][1] - ylo);
    if (delta <= 0.0) {
      if (update_history) tw[i] = 0.0;
      continue;
    }
    double xi = tw[i];
    if (update_history) xi += dt * (v[i][0] + radius[i] * omega[i][2]);
    const MindlinSmooth::Response res = MindlinSmooth::evaluate(p, delta, xi);
    if (update_history) tw[i] = res.xi;

    f[i][0] += res.ft;
    f[i][1] += res.fn;
    torque[i][2] += radius[i] * res.ft;

    out[0] = res.ft;
    out[1] = res.fn;
    out[2] = res.u;
    out[3] = res.xi;
    out[4] = delta;
    local[0] += 0.4 * res.fn * delta;
    local[1] += res.ft;
    local[2] += res.fn;
  }
}

/* ----------------------------------------------------------------------
   elastic (Hertz) energy stored in the wall contacts
------------------------------------------------------------------------- */

double FixWallMindlinSmooth::compute_scalar()
{
  if (!reduced) {
    MPI_Allreduce(local, total, 3, MPI_DOUBLE, MPI_SUM, world);
    reduced = 1;
  }
  return total[0];
}

/* ----------------------------------------------------------------------
   total force of the wall on the group: 0 = x, 1 = y
------------------------------------------------------------------------- */

double FixWallMindlinSmooth::compute_vector(int n)
{
  if (!reduced) {
    MPI_Allreduce(local, total, 3, MPI_DOUBLE, MPI_SUM, world);
    reduced = 1;
  }
  return total[n + 1];
}

/* ---------------------------------------------------------------------- */

double FixWallMindlinSmooth::memory_usage()
{
  return (double) nmax * NCOLS * sizeof(double);
}
