/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix wall/mindlin/smooth (LAMMPS plugin)

   fix ID group wall/mindlin/smooth k_n k_t mu wallstyle args
     wallstyle = xplane lo hi | yplane lo hi | zplane lo hi | yplane y_lo |
                 zcylinder R
       lo, hi = wall positions, NULL for an open side (zplane: 3d only)
       yplane y_lo = one floor (older decks; same as yplane y_lo NULL)
       zcylinder R = circle (3d: cylinder along z) of radius R about the
                     origin (z axis), particles inside

   Fixed walls with the contact law of pair style mindlin/smooth (2d or
   3d).  Each fix keeps one tangential displacement per particle and wall
   (a scalar in 2d, a vector in 3d) in a per-atom array of its own (carried
   with the atoms and in restart files), registered with Atom as the custom
   array d2_mindlin_wall_t_<ID> (nval columns per wall, wall w's in columns
   nval w ...), so that dumps, extract_atom and a driver that restores a
   state can read and write it.  The
   one-value form 'yplane y_lo' uses the per-atom vector d_mindlin_wall_t
   instead when a fix property/atom defines it (older decks, data files).
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
  void min_setup(int) override;
  void min_post_force(int) override;
  double compute_scalar() override;
  double compute_vector(int) override;
  double memory_usage() override;
  void *extract(const char *, int &) override;

  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;

  // one wall: a plane with its inward normal along +-x, +-y or +-z, or
  // the inside of a circle (cylinder) about the origin (z axis)
  struct Wall {
    int axis;         // 0 = x, 1 = y, 2 = z (planes); -1 = circle
    double sign;      // inward normal n = sign e_axis (planes)
    double pos;       // plane position or circle radius
  };

 protected:
  double kn, kt, mu;
  std::string mu_var;    // name of an equal-style variable for mu, if any
  int mu_ivar;
  Wall walls[2];
  int nwall;
  int dim3;             // 3d simulation
  int nval;              // history values per particle and wall: 1 (2d), 3 (3d)
  int nhist;             // nwall * nval
  int legacy_syntax;     // 'yplane y_lo' form
  int idx_legacy;        // index of d_mindlin_wall_t if this fix uses it, else -1
  int idx_hist;          // own history: custom array d2_mindlin_wall_t_<ID>, nhist columns
  int nmax_hist;
  double **hist() const;
  int nmax;              // rows allocated in array_atom
  double local[4], total[4];    // wall energy and force (fx, fy[, fz]) on this rank / all
  int reduced;

  double wall_arg(const char *, const char *);
};

}    // namespace LAMMPS_NS

#endif
