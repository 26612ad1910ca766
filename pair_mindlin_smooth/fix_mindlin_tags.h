/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix mindlin/tags (LAMMPS plugin), internal

   The atom ID each atom had when pair style mindlin/smooth last started a
   run (0: none yet -- an atom created since, or read from a data file),
   created by the pair (ID MINDLIN_TAGS).  The contact history names each
   partner by its atom ID; `delete_atoms` (compress yes, its default) and
   `reset_atoms id` give the atoms new IDs, and the pair uses these
   records to make the history follow them (PairMindlinSmooth::
   follow_new_ids).  The records move with their atoms between ranks and
   are carried by write_restart / read_restart; they are not in dumps or
   data files.
------------------------------------------------------------------------- */

#ifndef LMP_FIX_MINDLIN_TAGS_H
#define LMP_FIX_MINDLIN_TAGS_H

#include "fix.h"

#include <vector>

namespace LAMMPS_NS {

class FixMindlinTags : public Fix {
 public:
  static constexpr const char *ID = "MINDLIN_TAGS";

  FixMindlinTags(class LAMMPS *, int, char **);
  ~FixMindlinTags() override;

  int setmask() override { return 0; }

  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override { return 2; }
  int maxsize_restart() override { return 2; }
  double memory_usage() override;

  // Make the history rows of the owned atoms name their partners by the
  // new IDs, if any atom's ID changed since the records were made; then
  // record the present IDs (every rank calls it).  partner: the rows of
  // partner IDs, t: nt arrays of rows of t, ncol slots per row.  Returns,
  // on every rank, whether an atom with no record had history entries (a
  // history read from a data file or set by a driver, which no record can
  // make follow new IDs).
  bool follow_new_ids(int **partner, double **t[], int nt, int ncol);

  // every rank's tags, concatenated in rank order (every rank calls it)
  std::vector<tagint> everyones(const std::vector<tagint> &mine);

  tagint *previous;    // per atom: its ID at the start of the last run, 0 if none

 protected:
  int nrows;    // rows allocated
};

}    // namespace LAMMPS_NS

#endif
