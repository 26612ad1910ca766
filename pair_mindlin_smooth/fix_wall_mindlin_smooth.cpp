/* ----------------------------------------------------------------------
   remote-trigger: fix wall/mindlin/smooth (LAMMPS plugin)
------------------------------------------------------------------------- */

#include "fix_wall_mindlin_smooth.h"

#include "mindlin_smooth_kernel.h"
#include "mindlin_smooth_kernel_3d.h"
#include "mindlin_smooth_setup.h"

#include "atom.h"
#include "domain.h"
#include "error.h"
#include "input.h"
#include "memory.h"
#include "modify.h"
#include "update.h"
#include "variable.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

static const char HISTORY_WALL[] = "mindlin_wall_t";
static constexpr int NCOLS = 5;     // fx fy u t delta
static constexpr int NCOLS3 = 8;    // 3d: fx fy fz u t_x t_y t_z delta

static const char USAGE[] =
    "fix ID group wall/mindlin/smooth k_n k_t mu xplane|yplane|zplane lo hi (NULL = open "
    "side; zplane in 3d), yplane y_lo, or zcylinder R";

/* ---------------------------------------------------------------------- */

FixWallMindlinSmooth::FixWallMindlinSmooth(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), mu_ivar(-1), nwall(0), legacy_syntax(0), idx_legacy(-1),
    idx_hist(-1), nmax_hist(0), nmax(0), reduced(0)
{
  dim3 = (domain->dimension == 3);
  nval = dim3 ? 3 : 1;
  MindlinSmooth::refuse_rolling_twisting(lmp, "Fix wall/mindlin/smooth", narg, arg);
  if (narg < 8) error->all(FLERR, "Fix wall/mindlin/smooth needs: {}", USAGE);

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

  const std::string wstyle = arg[6];
  if (wstyle == "zplane" && !dim3)
    error->all(FLERR,
               "Fix wall/mindlin/smooth: zplane needs dimension 3, this simulation has "
               "dimension {}",
               domain->dimension);
  if (wstyle == "xplane" || wstyle == "yplane" || wstyle == "zplane") {
    const int axis = wstyle[0] - 'x';
    if (narg == 8 && axis == 1) {
      legacy_syntax = 1;
      walls[nwall++] = {1, 1.0, wall_arg(arg[7], "y_lo")};
    } else if (narg == 9) {
      if (strcmp(arg[7], "NULL") == 0 && strcmp(arg[8], "NULL") == 0)
        error->all(FLERR, "Fix wall/mindlin/smooth: {} lo and hi are both NULL: no wall",
                   wstyle);
      if (strcmp(arg[7], "NULL") != 0) walls[nwall++] = {axis, 1.0, wall_arg(arg[7], "lo")};
      if (strcmp(arg[8], "NULL") != 0) walls[nwall++] = {axis, -1.0, wall_arg(arg[8], "hi")};
      if (nwall == 2 && !(walls[0].pos < walls[1].pos))
        error->all(FLERR, "Fix wall/mindlin/smooth: {} lo must be below hi, got {} and {}",
                   wstyle, arg[7], arg[8]);
    } else {
      // a word after lo and hi is a keyword this fix does not have (walls
      // do not move: no wiggle or shear)
      if (narg > 9 && !utils::is_double(arg[9]))
        error->all(FLERR,
                   "Fix wall/mindlin/smooth: unknown keyword '{}' after {} {} {} (the fix "
                   "takes no keywords; its walls do not move)",
                   arg[9], wstyle, arg[7], arg[8]);
      error->all(FLERR, "Fix wall/mindlin/smooth: {} needs lo and hi (NULL for an open side), "
                        "got {} values",
                 wstyle, narg - 7);
    }
  } else if (wstyle == "zcylinder") {
    if (narg > 8 && !utils::is_double(arg[8]))
      error->all(FLERR,
                 "Fix wall/mindlin/smooth: unknown keyword '{}' after zcylinder {} (the fix "
                 "takes no keywords; its walls do not move)",
                 arg[8], arg[7]);
    if (narg != 8)
      error->all(FLERR, "Fix wall/mindlin/smooth: zcylinder needs one value (R), got {}",
                 narg - 7);
    const double rc = wall_arg(arg[7], "R");
    if (!(rc > 0.0))
      error->all(FLERR, "Fix wall/mindlin/smooth: zcylinder R must be > 0, got {}", arg[7]);
    walls[nwall++] = {-1, 1.0, rc};
  } else {
    error->all(FLERR, "Fix wall/mindlin/smooth: unknown wall style '{}'; use {}", wstyle,
               USAGE);
  }
  // a wall across a periodic dimension: atoms wrap around it (fix wall/gran refuses it too)
  for (int w = 0; w < nwall; w++) {
    const int a = walls[w].axis;
    if (a >= 0 && domain->periodicity[a])
      error->all(FLERR,
                 "Fix wall/mindlin/smooth: a {} wall needs a non-periodic {} dimension; "
                 "the boundary command makes it periodic",
                 wstyle, "xyz"[a]);
    if (a < 0 && (domain->periodicity[0] || domain->periodicity[1]))
      error->all(FLERR,
                 "Fix wall/mindlin/smooth: zcylinder needs non-periodic x and y dimensions; "
                 "the boundary command makes {} periodic",
                 domain->periodicity[0] ? "x" : "y");
  }

  scalar_flag = 1;
  vector_flag = 1;
  size_vector = dim3 ? 3 : 2;
  global_freq = 1;
  extscalar = 1;
  extvector = 1;
  energy_global_flag = 1;
  peratom_flag = 1;
  size_peratom_cols = dim3 ? NCOLS3 : NCOLS;
  peratom_freq = 1;
  array_atom = nullptr;
  for (int k = 0; k < 4; k++) local[k] = total[k] = 0.0;

  // own history, one value (3d: three) per disk and wall
  restart_peratom = 1;
  create_attribute = 1;
  nhist = nwall * nval;
  maxexchange = nhist;
  const std::string hname = std::string(HISTORY_WALL) + "_" + id;
  int flag, cols;
  if (atom->find_custom(hname.c_str(), flag, cols) >= 0)
    error->all(FLERR,
               "Fix wall/mindlin/smooth {}: per-atom array d2_{} already exists (from a fix "
               "property/atom?)",
               id, hname);
  idx_hist = atom->add_custom(hname.c_str(), 1, nhist);
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
}

/* ---------------------------------------------------------------------- */

FixWallMindlinSmooth::~FixWallMindlinSmooth()
{
  if (copymode) return;
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  atom->remove_custom(idx_hist, 1, nhist);
  memory->destroy(array_atom);
}

/* ---------------------------------------------------------------------- */

double FixWallMindlinSmooth::wall_arg(const char *str, const char *what)
{
  const double val = utils::numeric(FLERR, str, false, lmp);
  if (!std::isfinite(val))
    error->all(FLERR, "Fix wall/mindlin/smooth: {} must be a finite number, got {}", what, str);
  return val;
}

/* ---------------------------------------------------------------------- */

int FixWallMindlinSmooth::setmask()
{
  return POST_FORCE | MIN_POST_FORCE;
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::init()
{
  MindlinSmooth::require_spheres(lmp, "Fix wall/mindlin/smooth");
  MindlinSmooth::forbid_respa(lmp, "Fix wall/mindlin/smooth");

  // older decks: 'yplane y_lo' with d_mindlin_wall_t from a fix property/atom
  idx_legacy = -1;
  int flag, cols;
  const int idx = atom->find_custom(HISTORY_WALL, flag, cols);
  if (legacy_syntax && idx >= 0 && dim3)
    error->all(FLERR,
               "Fix wall/mindlin/smooth {}: d_{} holds one value per atom, the 2d history; in "
               "3d the fix keeps its history itself: drop d_{} from the fix property/atom",
               id, HISTORY_WALL, HISTORY_WALL);
  if (legacy_syntax && idx >= 0) {
    if (flag != 1 || cols != 0)
      error->all(FLERR, "Fix wall/mindlin/smooth: d_{} must be a per-atom double vector",
                 HISTORY_WALL);
    for (auto *other : modify->get_fix_by_style("^wall/mindlin/smooth$")) {
      if (other == this) break;
      if (((FixWallMindlinSmooth *) other)->idx_legacy >= 0)
        error->all(FLERR,
                   "Fix wall/mindlin/smooth: fixes {} and {} would both keep their history "
                   "in d_{}; give one of them the form 'yplane lo hi'",
                   other->id, id, HISTORY_WALL);
    }
    idx_legacy = idx;
  }

  if (!mu_var.empty()) {
    mu_ivar = input->variable->find(mu_var.c_str());
    if (mu_ivar < 0)
      error->all(FLERR, "Fix wall/mindlin/smooth: variable {} for mu does not exist", mu_var);
    if (!input->variable->equalstyle(mu_ivar))
      error->all(FLERR, "Fix wall/mindlin/smooth: variable {} for mu is not equal-style",
                 mu_var);
  }
  // minimize only without friction (mu of a variable: its value now)
  if (update->whichflag == 2) {
    const double mu_now = (mu_ivar >= 0) ? input->variable->compute_equal(mu_ivar) : mu;
    MindlinSmooth::forbid_minimize(lmp, "Fix wall/mindlin/smooth", mu_now * kt == 0.0);
  }
}

/* ---------------------------------------------------------------------- */

void FixWallMindlinSmooth::setup(int vflag)
{
  post_force(vflag);
}

/* ----------------------------------------------------------------------
   energy minimization (frictionless walls only, see init): the same forces
------------------------------------------------------------------------- */

void FixWallMindlinSmooth::min_setup(int vflag)
{
  post_force(vflag);
}

void FixWallMindlinSmooth::min_post_force(int vflag)
{
  post_force(vflag);
}

/* ---------------------------------------------------------------------- */

/* ----------------------------------------------------------------------
   forces of one wall on every atom of the group, for one kind of wall
   (KIND = 1: yplane, 0: xplane, -1: zcylinder); the same contact step as
   pair mindlin/smooth (MindlinSmooth::step)
------------------------------------------------------------------------- */

namespace {
struct WallArrays {
  double **x, **v, **f, **omega, **torque, **out;
  const double *radius;
  const int *mask;
  int groupbit, nlocal, update_history, stride;
  double dt;
  double *stored;
  MindlinSmooth::Params p;
};

template <int KIND>
void wall_pass(const WallArrays &a, const FixWallMindlinSmooth::Wall &wall, double *local,
               Error *error = nullptr, const tagint *tag = nullptr)
{
  for (int i = 0; i < a.nlocal; i++) {
    if (!(a.mask[i] & a.groupbit)) continue;
    const double radi = a.radius[i];
    double &stored = a.stored[(bigint) i * a.stride];
    double delta, nx, ny;
    if (KIND >= 0) {
      // plane: n = sign e_axis
      delta = radi - wall.sign * (a.x[i][KIND] - wall.pos);
      nx = (KIND == 0) ? wall.sign : 0.0;
      ny = (KIND == 1) ? wall.sign : 0.0;
    } else {
      // inside of a circle of radius pos about the origin: n points inward
      const double d = sqrt(a.x[i][0] * a.x[i][0] + a.x[i][1] * a.x[i][1]);
      delta = radi + d - wall.pos;
      if (delta > 0.0 && d == 0.0)
        error->one(FLERR,
                   "Fix wall/mindlin/smooth: atom {} (radius {}) at the centre of zcylinder "
                   "R = {} has no contact normal",
                   tag[i], radi, wall.pos);
      nx = (delta > 0.0) ? -a.x[i][0] / d : 0.0;
      ny = (delta > 0.0) ? -a.x[i][1] / d : 0.0;
    }
    if (delta <= 0.0) {
      if (a.update_history) stored = 0.0;
      continue;
    }

    // tangent s = (ny, -nx); for a plane one component, taken exactly
    double slip;
    if (KIND == 1)
      slip = ny * a.v[i][0];
    else if (KIND == 0)
      slip = -nx * a.v[i][1];
    else
      slip = ny * a.v[i][0] - nx * a.v[i][1];
    slip += radi * a.omega[i][2];
    const MindlinSmooth::Response res =
        MindlinSmooth::step(a.p, delta, stored, slip, a.dt, a.update_history);
    if (a.update_history) stored = res.xi;

    // F = fn n + ft s
    double fx, fy;
    if (KIND == 1) {
      fx = ny * res.ft;
      fy = ny * res.fn;
    } else if (KIND == 0) {
      fx = nx * res.fn;
      fy = -nx * res.ft;
    } else {
      fx = res.fn * nx + res.ft * ny;
      fy = res.fn * ny - res.ft * nx;
    }
    a.f[i][0] += fx;
    a.f[i][1] += fy;
    a.torque[i][2] += radi * res.ft;

    double *out = a.out[i];
    out[0] += fx;
    out[1] += fy;
    out[2] = res.u;
    out[3] = res.xi;
    out[4] = delta;
    local[0] += 0.4 * res.fn * delta;
    local[1] += fx;
    local[2] += fy;
  }
}

/* ----------------------------------------------------------------------
   the same in 3d (KIND = 0, 1, 2: x-, y-, zplane; -1: zcylinder), the
   law of mindlin_smooth_kernel_3d.h with v_j = 0, om_j = 0; three history
   values per atom at a.stored + i * a.stride
------------------------------------------------------------------------- */

template <int KIND>
void wall_pass3(const WallArrays &a, const FixWallMindlinSmooth::Wall &wall, double *local,
                Error *error = nullptr, const tagint *tag = nullptr)
{
  const double zero[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < a.nlocal; i++) {
    if (!(a.mask[i] & a.groupbit)) continue;
    const double radi = a.radius[i];
    double *stored = a.stored + (bigint) i * a.stride;
    double delta;
    double n[3] = {0.0, 0.0, 0.0};
    if (KIND >= 0) {
      delta = radi - wall.sign * (a.x[i][KIND] - wall.pos);
      n[KIND] = wall.sign;
    } else {
      // inside of a cylinder of radius pos about the z axis: n points inward
      const double d = sqrt(a.x[i][0] * a.x[i][0] + a.x[i][1] * a.x[i][1]);
      delta = radi + d - wall.pos;
      if (delta > 0.0 && d == 0.0)
        error->one(FLERR,
                   "Fix wall/mindlin/smooth: atom {} (radius {}) on the axis of zcylinder "
                   "R = {} has no contact normal",
                   tag[i], radi, wall.pos);
      if (delta > 0.0) {
        n[0] = -a.x[i][0] / d;
        n[1] = -a.x[i][1] / d;
      }
    }
    if (delta <= 0.0) {
      if (a.update_history)
        for (int k = 0; k < 3; k++) stored[k] = 0.0;
      continue;
    }

    double slip[3] = {0.0, 0.0, 0.0};
    if (a.update_history) {
      double w[3];
      for (int k = 0; k < 3; k++) w[k] = radi * a.omega[i][k];
      MindlinSmooth::slip3(n, a.v[i], w, slip);
    }
    const MindlinSmooth::Response3 res =
        MindlinSmooth::step3(a.p, delta, n, stored, a.update_history ? slip : zero, a.dt,
                             a.update_history);
    double tq[3];
    MindlinSmooth::torque3(radi, n, res.ft, tq);
    double *out = a.out[i];
    local[0] += 0.4 * res.fn * delta;
    for (int k = 0; k < 3; k++) {
      if (a.update_history) stored[k] = res.t[k];
      const double fk = res.fn * n[k] + res.ft[k];
      a.f[i][k] += fk;
      a.torque[i][k] += tq[k];
      out[k] += fk;
      out[4 + k] = res.t[k];
      local[1 + k] += fk;
    }
    out[3] = res.u;
    out[7] = delta;
  }
}
}    // namespace

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
    memory->create(array_atom, nmax, size_peratom_cols, "wall/mindlin/smooth:array_atom");
  }

  const int nlocal = atom->nlocal;
  WallArrays a;
  a.x = atom->x;
  a.v = atom->v;
  a.f = atom->f;
  a.omega = atom->omega;
  a.torque = atom->torque;
  a.radius = atom->radius;
  a.mask = atom->mask;
  a.groupbit = groupbit;
  a.nlocal = nlocal;
  a.update_history = (update->setupflag == 0);
  a.dt = update->dt;
  a.p = {kn, kt, mu};
  a.out = array_atom;

  for (int k = 0; k < 4; k++) local[k] = 0.0;
  reduced = 0;
  if (nlocal > 0) memset(array_atom[0], 0, sizeof(double) * nlocal * size_peratom_cols);

  // one pass over the atoms per wall, specialised to the wall's kind (the
  // per-atom loop stays as short as the one-floor loop of older versions);
  // per atom the walls add their forces in the same order as before
  for (int w = 0; w < nwall; w++) {
    const Wall &wall = walls[w];
    // history of this wall: d_mindlin_wall_t (legacy form, 2d), or
    // columns nval w ... of the fix's own contiguous nmax x nhist array
    if (idx_legacy >= 0) {
      a.stored = atom->dvector[idx_legacy];
      a.stride = 1;
    } else {
      a.stored = (nlocal > 0) ? hist()[0] + nval * w : nullptr;
      a.stride = nhist;
    }
    if (dim3) {
      if (wall.axis == 0)
        wall_pass3<0>(a, wall, local);
      else if (wall.axis == 1)
        wall_pass3<1>(a, wall, local);
      else if (wall.axis == 2)
        wall_pass3<2>(a, wall, local);
      else
        wall_pass3<-1>(a, wall, local, error, atom->tag);
    } else if (wall.axis == 1)
      wall_pass<1>(a, wall, local);
    else if (wall.axis == 0)
      wall_pass<0>(a, wall, local);
    else
      wall_pass<-1>(a, wall, local, error, atom->tag);
  }
}

/* ----------------------------------------------------------------------
   elastic (Hertz) energy stored in the wall contacts
------------------------------------------------------------------------- */

double FixWallMindlinSmooth::compute_scalar()
{
  if (!reduced) {
    MPI_Allreduce(local, total, 1 + size_vector, MPI_DOUBLE, MPI_SUM, world);
    reduced = 1;
  }
  return total[0];
}

/* ----------------------------------------------------------------------
   total force of the walls on the group: 0 = x, 1 = y (, 2 = z in 3d)
------------------------------------------------------------------------- */

double FixWallMindlinSmooth::compute_vector(int n)
{
  if (!reduced) {
    MPI_Allreduce(local, total, 1 + size_vector, MPI_DOUBLE, MPI_SUM, world);
    reduced = 1;
  }
  return total[n + 1];
}

/* ----------------------------------------------------------------------
   mu (dim 0) for fix mu/velocity, unless a variable gives it
------------------------------------------------------------------------- */

void *FixWallMindlinSmooth::extract(const char *str, int &dim)
{
  dim = 0;
  if (strcmp(str, "mu") == 0 && mu_var.empty()) return (void *) &mu;
  return nullptr;
}

/* ----------------------------------------------------------------------
   own history rows: nhist = nwall x nval values per atom (wall w's in
   nval w ... nval w + nval - 1), moved with the atom
------------------------------------------------------------------------- */

double **FixWallMindlinSmooth::hist() const
{
  return atom->darray[idx_hist];
}

void FixWallMindlinSmooth::grow_arrays(int n)
{
  memory->grow(atom->darray[idx_hist], n, nhist, "wall/mindlin/smooth:history");
  for (int i = nmax_hist; i < n; i++) set_arrays(i);
  nmax_hist = n;
}

void FixWallMindlinSmooth::copy_arrays(int i, int j, int /*delflag*/)
{
  for (int k = 0; k < nhist; k++) hist()[j][k] = hist()[i][k];
}

void FixWallMindlinSmooth::set_arrays(int i)
{
  for (int k = 0; k < nhist; k++) hist()[i][k] = 0.0;
}

int FixWallMindlinSmooth::pack_exchange(int i, double *buf)
{
  for (int k = 0; k < nhist; k++) buf[k] = hist()[i][k];
  return nhist;
}

int FixWallMindlinSmooth::unpack_exchange(int nlocal, double *buf)
{
  for (int k = 0; k < nhist; k++) hist()[nlocal][k] = buf[k];
  return nhist;
}

int FixWallMindlinSmooth::pack_restart(int i, double *buf)
{
  buf[0] = nhist + 1;
  for (int k = 0; k < nhist; k++) buf[k + 1] = hist()[i][k];
  return nhist + 1;
}

void FixWallMindlinSmooth::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  const int nstored = static_cast<int>(extra[nlocal][m]) - 1;
  if (nstored != nhist)
    error->one(FLERR,
               "Fix wall/mindlin/smooth {}: the restart file has {} walls for this fix ID, "
               "the command {}",
               id, nstored / nval, nwall);
  for (int k = 0; k < nhist; k++) hist()[nlocal][k] = extra[nlocal][m + 1 + k];
}

int FixWallMindlinSmooth::size_restart(int /*nlocal*/)
{
  return nhist + 1;
}

int FixWallMindlinSmooth::maxsize_restart()
{
  return nhist + 1;
}

/* ---------------------------------------------------------------------- */

double FixWallMindlinSmooth::memory_usage()
{
  return (double) nmax * size_peratom_cols * sizeof(double) +
      (double) nmax_hist * nhist * sizeof(double);
}
