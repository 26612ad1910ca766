/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix wall/mindlin/smooth (LAMMPS plugin)

   fix ID group wall/mindlin/smooth k_n k_t mu yplane y_lo

   A flat, fixed wall below the disks with the contact law of pair style
   mindlin/smooth.  Per-disk history in the per-atom vector
   d_mindlin_wall_t of a fix property/atom.
------------------------------------------------------------------------- */

#ifndef LMP_FIX_WALL_MINDLIN_SMOOTH_H
#define LMP_FIX_WALL_MINDLIN_SMOOTH_H

#include "fix.h"

#include <string>

namespace LAMMPS_NS {

class FixWallMindlinSmooth : public Fix {
 public:
  FixWallMindlinSmooth(class LAMMPS *, int, char **);
  ~FixWallMindlinSmooth() override;

  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_scalar() override;
  double compute_vector(int) override;
  double memory_usage() override;

 protected:
  double kn, kt, mu, ylo;
  std::string mu_var;    // name of an equal-style variable for mu, if any
  int mu_ivar;
  int idx_t;             // index of the d_mindlin_wall_t per-atom vector
  int nmax;              // rows allocated in array_atom
  double local[3], total[3];    // wall energy and force (fx, fy) on this rank / all
  int reduced;

  void find_history();
};

}    // namespace LAMMPS_NS

#endif
