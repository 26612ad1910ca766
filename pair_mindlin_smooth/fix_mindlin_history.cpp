/* ----------------------------------------------------------------------
   remote-trigger: fix mindlin/history (LAMMPS plugin), internal
------------------------------------------------------------------------- */

#include "fix_mindlin_history.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "memory.h"
#include "utils.h"

#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

static const char *const PARTNER = FixMindlinHistory::PARTNER;

/* ---------------------------------------------------------------------- */

FixMindlinHistory::FixMindlinHistory(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), idx_partner(-1), idx_t{-1, -1, -1}, ncol(START_COLUMNS),
    nval((domain->dimension == 3) ? 3 : 1), nrows(0)
{
  if (narg != 3)
    error->all(FLERR, "Fix mindlin/history is created by pair style mindlin/smooth and takes "
                      "no arguments");
  int flag, cols;
  for (int c = -1; c < nval; c++) {
    const char *name = (c < 0) ? PARTNER : t_name(c);
    if (atom->find_custom(name, flag, cols) >= 0)
      error->all(FLERR,
                 "Fix mindlin/history: per-atom array {} already exists (from a fix "
                 "property/atom?)",
                 name);
  }

  restart_global = 1;
  restart_peratom = 1;
  create_attribute = 1;
  maxexchange_dynamic = 1;
  maxexchange = 1 + (1 + nval) * ncol;

  idx_partner = atom->add_custom(PARTNER, 0, ncol);
  for (int c = 0; c < nval; c++) idx_t[c] = atom->add_custom(t_name(c), 1, ncol);
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
}

/* ---------------------------------------------------------------------- */

FixMindlinHistory::~FixMindlinHistory()
{
  if (copymode) return;
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  atom->remove_custom(idx_partner, 0, ncol);
  for (int c = 0; c < nval; c++) atom->remove_custom(idx_t[c], 1, ncol);
}

/* ---------------------------------------------------------------------- */

int FixMindlinHistory::setmask()
{
  return POST_NEIGHBOR;
}

/* ----------------------------------------------------------------------
   all ranks adopt the largest column count at every neighbor-list build,
   so that dumps and gathers see one width
------------------------------------------------------------------------- */

void FixMindlinHistory::setup_post_neighbor()
{
  agree_on_columns();
}

void FixMindlinHistory::post_neighbor()
{
  agree_on_columns();
}

void FixMindlinHistory::agree_on_columns()
{
  int all;
  MPI_Allreduce(&ncol, &all, 1, MPI_INT, MPI_MAX, world);
  if (all > ncol) set_columns(all);
}

/* ----------------------------------------------------------------------
   fix_modify MINDLIN_HISTORY columns N: at least N slots on every rank
------------------------------------------------------------------------- */

int FixMindlinHistory::modify_param(int narg, char **arg)
{
  if (strcmp(arg[0], "columns") != 0) return 0;
  if (narg < 2) error->all(FLERR, "Fix_modify {} columns needs a number", id);
  const int n = utils::inumeric(FLERR, arg[1], false, lmp);
  if (n < 1) error->all(FLERR, "Fix_modify {} columns must be >= 1, got {}", id, arg[1]);
  if (n > ncol) set_columns(n);
  agree_on_columns();
  return 2;
}

/* ----------------------------------------------------------------------
   global state: the column count (read back before the rows arrive)
------------------------------------------------------------------------- */

void FixMindlinHistory::write_restart(FILE *fp)
{
  agree_on_columns();    // called on every rank: maxsize_restart() is then global
  if (comm->me == 0) {
    const int size = sizeof(int);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(&ncol, sizeof(int), 1, fp);
  }
}

void FixMindlinHistory::restart(char *buf)
{
  int n;
  memcpy(&n, buf, sizeof(int));
  reserve(n);
}

/* ---------------------------------------------------------------------- */

void FixMindlinHistory::set_columns(int n)
{
  const int keep = (n < ncol) ? n : ncol;
  int **p_old = atom->iarray[idx_partner];
  int **p_new = nullptr;
  memory->create(p_new, nrows, n, "mindlin/history:partner");
  for (int i = 0; i < nrows; i++) {
    for (int k = 0; k < keep; k++) p_new[i][k] = p_old[i][k];
    for (int k = keep; k < n; k++) p_new[i][k] = 0;
  }
  memory->destroy(p_old);
  atom->iarray[idx_partner] = p_new;
  atom->icols[idx_partner] = n;
  for (int c = 0; c < nval; c++) {
    double **t_old = atom->darray[idx_t[c]];
    double **t_new = nullptr;
    memory->create(t_new, nrows, n, "mindlin/history:t");
    for (int i = 0; i < nrows; i++) {
      for (int k = 0; k < keep; k++) t_new[i][k] = t_old[i][k];
      for (int k = keep; k < n; k++) t_new[i][k] = 0.0;
    }
    memory->destroy(t_old);
    atom->darray[idx_t[c]] = t_new;
    atom->dcols[idx_t[c]] = n;
  }
  ncol = n;
  maxexchange = 1 + (1 + nval) * ncol;
}

void FixMindlinHistory::reserve(int n)
{
  if (n <= ncol) return;
  set_columns((n > 2 * ncol) ? n : 2 * ncol);
}

/* ---------------------------------------------------------------------- */

int FixMindlinHistory::filled(int i) const
{
  const int *p = atom->iarray[idx_partner][i];
  int n = 0;
  while (n < ncol && p[n] != 0) n++;
  return n;
}

/* ---------------------------------------------------------------------- */

void FixMindlinHistory::grow_arrays(int nmax)
{
  memory->grow(atom->iarray[idx_partner], nmax, ncol, "mindlin/history:partner");
  for (int c = 0; c < nval; c++)
    memory->grow(atom->darray[idx_t[c]], nmax, ncol, "mindlin/history:t");
  for (int i = nrows; i < nmax; i++) set_arrays(i);
  nrows = nmax;
}

void FixMindlinHistory::copy_arrays(int i, int j, int /*delflag*/)
{
  memcpy(atom->iarray[idx_partner][j], atom->iarray[idx_partner][i], ncol * sizeof(int));
  for (int c = 0; c < nval; c++)
    memcpy(atom->darray[idx_t[c]][j], atom->darray[idx_t[c]][i], ncol * sizeof(double));
}

void FixMindlinHistory::set_arrays(int i)
{
  memset(atom->iarray[idx_partner][i], 0, ncol * sizeof(int));
  for (int c = 0; c < nval; c++) memset(atom->darray[idx_t[c]][i], 0, ncol * sizeof(double));
}

/* ----------------------------------------------------------------------
   one atom's filled slots: n, then n (partner, t) records, t of nval values
------------------------------------------------------------------------- */

int FixMindlinHistory::pack_exchange(int i, double *buf)
{
  const int n = filled(i);
  const int *p = atom->iarray[idx_partner][i];
  int m = 0;
  buf[m++] = ubuf(n).d;
  for (int k = 0; k < n; k++) {
    buf[m++] = ubuf(p[k]).d;
    for (int c = 0; c < nval; c++) buf[m++] = atom->darray[idx_t[c]][i][k];
  }
  return m;
}

int FixMindlinHistory::unpack_exchange(int nlocal, double *buf)
{
  const int n = (int) ubuf(buf[0]).i;
  reserve(n);
  set_arrays(nlocal);
  int *p = atom->iarray[idx_partner][nlocal];
  int m = 1;
  for (int k = 0; k < n; k++) {
    p[k] = (int) ubuf(buf[m++]).i;
    for (int c = 0; c < nval; c++) atom->darray[idx_t[c]][nlocal][k] = buf[m++];
  }
  return m;
}

/* ----------------------------------------------------------------------
   restart rows: total size first (LAMMPS convention), then as exchange
------------------------------------------------------------------------- */

int FixMindlinHistory::pack_restart(int i, double *buf)
{
  const int m = pack_exchange(i, buf + 1);
  buf[0] = m + 1;
  return m + 1;
}

void FixMindlinHistory::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  unpack_exchange(nlocal, &extra[nlocal][m + 1]);
}

int FixMindlinHistory::size_restart(int nlocal)
{
  return 2 + (1 + nval) * filled(nlocal);
}

int FixMindlinHistory::maxsize_restart()
{
  return 2 + (1 + nval) * ncol;
}

/* ---------------------------------------------------------------------- */

double FixMindlinHistory::memory_usage()
{
  return (double) nrows * ncol * (sizeof(int) + nval * sizeof(double));
}
