/* ----------------------------------------------------------------------
   remote-trigger: fix mindlin/tags (LAMMPS plugin), internal
------------------------------------------------------------------------- */

#include "fix_mindlin_tags.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "memory.h"
#include "utils.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

FixMindlinTags::FixMindlinTags(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), previous(nullptr), nrows(0)
{
  if (narg != 3)
    error->all(FLERR, "Fix mindlin/tags is created by pair style mindlin/smooth and takes "
                      "no arguments");
  restart_peratom = 1;
  create_attribute = 1;
  maxexchange = 1;
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
}

FixMindlinTags::~FixMindlinTags()
{
  if (copymode) return;
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  memory->destroy(previous);
}

/* ---------------------------------------------------------------------- */

void FixMindlinTags::grow_arrays(int nmax)
{
  // new rows have no record (also the atoms that exist when the fix is made)
  memory->grow(previous, nmax, "mindlin/tags:previous");
  for (int i = nrows; i < nmax; i++) previous[i] = 0;
  nrows = nmax;
}

void FixMindlinTags::copy_arrays(int i, int j, int /*delflag*/)
{
  previous[j] = previous[i];
}

void FixMindlinTags::set_arrays(int i)
{
  previous[i] = 0;
}

int FixMindlinTags::pack_exchange(int i, double *buf)
{
  buf[0] = ubuf(previous[i]).d;
  return 1;
}

int FixMindlinTags::unpack_exchange(int nlocal, double *buf)
{
  previous[nlocal] = (tagint) ubuf(buf[0]).i;
  return 1;
}

/* restart rows: size first (LAMMPS convention), then the record */

int FixMindlinTags::pack_restart(int i, double *buf)
{
  buf[0] = 2;
  buf[1] = ubuf(previous[i]).d;
  return 2;
}

void FixMindlinTags::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  previous[nlocal] = (tagint) ubuf(extra[nlocal][m + 1]).i;
}

/* ----------------------------------------------------------------------
   The history after new atom IDs.  Each atom's record is the ID it had
   when the last run started; where one differs from the atom's ID now
   (delete_atoms compress yes, reset_atoms id), every rank learns every
   (old ID -> new ID) pair and rewrites its rows: a partner that is still
   there gets its new ID (its slot keeps its t), one that was deleted is
   dropped, and each row is written again packed and in ascending partner
   ID.  An old ID that several atoms now carry as their record (replicate
   copies the records) cannot be followed: those slots are dropped too,
   with a warning -- their contacts start again from zero tangential
   displacement.  A slot naming an atom with no record (created since, or
   read from a data file) by its present ID is kept as it is.
------------------------------------------------------------------------- */

bool FixMindlinTags::follow_new_ids(int **partner, double **t[], int nt, int ncol)
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  // [0]: an ID changed since its record; [1]: an atom with no record has
  // history entries (one reduction for both)
  int flags[2] = {0, 0}, any[2] = {0, 0};
  for (int i = 0; i < nlocal; i++) {
    if (previous[i] != 0 && previous[i] != tag[i]) flags[0] = 1;
    if (previous[i] == 0)
      for (int k = 0; k < ncol && !flags[1]; k++) flags[1] = (partner[i][k] != 0);
  }
  MPI_Allreduce(flags, any, 2, MPI_INT, MPI_MAX, world);
  if (any[0]) {
    // every (old, new) pair on every rank; old = 0 for an atom with no record
    std::vector<tagint> mine(2 * (size_t) nlocal);
    for (int i = 0; i < nlocal; i++) {
      mine[2 * i] = previous[i];
      mine[2 * i + 1] = tag[i];
    }
    const std::vector<tagint> all = everyones(mine);
    // old -> new (0: the old ID of several atoms); an atom with no record
    // keeps the ID the history may name it by
    std::unordered_map<tagint, tagint> renamed;
    std::unordered_set<tagint> unrecorded;
    for (size_t k = 0; k < all.size(); k += 2) {
      if (all[k] == 0) {
        unrecorded.insert(all[k + 1]);
        continue;
      }
      auto it = renamed.find(all[k]);
      if (it == renamed.end())
        renamed.emplace(all[k], all[k + 1]);
      else
        it->second = 0;
    }

    bigint dropped_ambiguous = 0;
    std::vector<std::pair<tagint, int>> kept;    // (new partner ID, slot)
    std::vector<double> row;
    for (int i = 0; i < nlocal; i++) {
      int *p = partner[i];
      kept.clear();
      for (int k = 0; k < ncol && p[k] != 0; k++) {
        auto it = renamed.find(p[k]);
        if (it == renamed.end()) {
          // a partner with no record keeps its ID; any other is gone
          if (unrecorded.count(p[k])) kept.emplace_back(p[k], k);
          continue;
        }
        if (it->second == 0) {
          dropped_ambiguous++;
          continue;
        }
        kept.emplace_back(it->second, k);
      }
      std::sort(kept.begin(), kept.end());
      for (int c = 0; c < nt; c++) {
        row.assign(t[c][i], t[c][i] + ncol);
        for (int k = 0; k < ncol; k++)
          t[c][i][k] = (k < (int) kept.size()) ? row[kept[k].second] : 0.0;
      }
      for (int k = 0; k < ncol; k++) p[k] = (k < (int) kept.size()) ? (int) kept[k].first : 0;
    }
    bigint total = 0;
    MPI_Allreduce(&dropped_ambiguous, &total, 1, MPI_LMP_BIGINT, MPI_SUM, world);
    if (comm->me == 0) {
      utils::logmesg(lmp, "Pair style mindlin/smooth: atom IDs changed since the last run "
                          "(delete_atoms, reset_atoms id): the contact history follows the "
                          "new IDs\n");
      if (total > 0)
        error->warning(FLERR,
                       "Pair style mindlin/smooth: {} history entries named an atom ID that "
                       "several atoms now had before (replicate?); their contacts start again "
                       "from zero tangential displacement",
                       total);
    }
  }
  for (int i = 0; i < nlocal; i++) previous[i] = tag[i];
  return any[1] != 0;
}

/* the concatenation, in rank order, of every rank's ``mine`` (collective) */

std::vector<tagint> FixMindlinTags::everyones(const std::vector<tagint> &mine)
{
  const int n = (int) mine.size();
  std::vector<int> counts(comm->nprocs), offsets(comm->nprocs, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  for (int p = 1; p < comm->nprocs; p++) offsets[p] = offsets[p - 1] + counts[p - 1];
  std::vector<tagint> all((size_t) offsets.back() + counts.back());
  MPI_Allgatherv(mine.data(), n, MPI_LMP_TAGINT, all.data(), counts.data(), offsets.data(),
                 MPI_LMP_TAGINT, world);
  return all;
}

double FixMindlinTags::memory_usage()
{
  return (double) atom->nmax * sizeof(tagint);
}
