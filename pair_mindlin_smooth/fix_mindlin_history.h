/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix mindlin/history (LAMMPS plugin), internal

   Per-contact history of pair style mindlin/smooth, created by the pair
   (ID MINDLIN_HISTORY) when no fix property/atom defines the arrays.
   It owns two per-atom custom arrays, registered with Atom under the
   names the property/atom path uses, so dumps, extract_atom and gather
   see them as i2_mindlin_partner[*] and d2_mindlin_t[*]:

     mindlin_partner[i][k]   partner atom ID of contact k of atom i
                             (0 = empty; filled slots come first)
     mindlin_t[i][k]         atom i's side of that contact's tangential
                             displacement (2d: the signed scalar xi)
     mindlin_tx/ty/tz[i][k]  in 3d, instead of mindlin_t: the components of
                             the vector t (three arrays, so that each line
                             of a data-file section stays short: LAMMPS
                             read_data reads lines of at most 255 characters)

   The number of columns starts at 8 and grows when an atom needs more
   (on its own rank at once; all ranks agree again at the next
   reneighboring and before a restart file is written).  Rows move with
   their atoms between ranks and are carried by write_restart /
   read_restart (the pair re-creates this fix with the same ID).

     fix_modify MINDLIN_HISTORY columns N   makes room for N contacts per
                             atom on every rank (never shrinks), so that a
                             driver can write a wider saved history back
                             with extract_atom.
------------------------------------------------------------------------- */

#ifndef LMP_FIX_MINDLIN_HISTORY_H
#define LMP_FIX_MINDLIN_HISTORY_H

#include "fix.h"

namespace LAMMPS_NS {

class FixMindlinHistory : public Fix {
 public:
  static constexpr const char *ID = "MINDLIN_HISTORY";
  static constexpr int START_COLUMNS = 8;
  // names of the per-atom arrays (without the i2_ / d2_ prefix)
  static constexpr const char *PARTNER = "mindlin_partner";
  static constexpr const char *T_2D = "mindlin_t";
  static constexpr const char *T_3D[3] = {"mindlin_tx", "mindlin_ty", "mindlin_tz"};

  FixMindlinHistory(class LAMMPS *, int, char **);
  ~FixMindlinHistory() override;

  int setmask() override;
  void setup_post_neighbor() override;
  int modify_param(int, char **) override;
  void post_neighbor() override;

  void write_restart(FILE *) override;
  void restart(char *) override;

  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;
  double memory_usage() override;

  // make room for at least n contacts per atom on this rank
  void reserve(int n);

 protected:
  int idx_partner, idx_t[3];    // indices of the custom arrays in Atom
  int ncol;                     // columns of every array (contact slots) on this rank
  int nval;                     // arrays of t: 1 (2d, mindlin_t), 3 (3d, mindlin_tx/ty/tz)

  const char *t_name(int c) const { return (nval == 3) ? T_3D[c] : T_2D; }
  int nrows;                 // rows allocated

  int filled(int i) const;
  void set_columns(int);
  void agree_on_columns();
};

}    // namespace LAMMPS_NS

#endif
