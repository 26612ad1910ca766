/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix mu/velocity (LAMMPS plugin)

   fix ID group mu/velocity mu0 v0 B w mu_ss keyword value ...
     keywords: vss V (default v0), pair yes|no, wall yes|no

   Velocity-dependent friction, Eq. 4 of Charan, Pomyalov & Procaccia:
   once per step, before the forces, the group's mean (centre-of-mass)
   x-velocity v gives

     mu = mu0                                        for |v|/vss <= v0/vss
     mu = mu0 (B exp(-w (|v| - v0)/vss) + mu_ss)     otherwise,

   which the fix writes into the coefficient mu of pair style
   mindlin/smooth (every type pair) and of every fix wall/mindlin/smooth.
   The same value as an equal-style variable with fix adapt, without
   parsing a variable or re-initialising the pair every step.
------------------------------------------------------------------------- */

#ifndef LMP_FIX_MU_VELOCITY_H
#define LMP_FIX_MU_VELOCITY_H

#include "fix.h"

#include <vector>

namespace LAMMPS_NS {

class FixMuVelocity : public Fix {
 public:
  FixMuVelocity(class LAMMPS *, int, char **);

  int setmask() override;
  void init() override;
  void setup_pre_force(int) override;
  void pre_force(int) override;
  double compute_vector(int) override;

  void write_restart(FILE *) override;
  void restart(char *) override;

 protected:
  double mu0, v0, B, w, muss, vss;
  int pairflag, wallflag;
  double mu;         // friction coefficient of the current step
  double vcm;        // the group's mean x-velocity it was computed from
  double vmax;       // largest |vcm| over every step since the fix was defined
  double tswitch;    // time of the first step with |vcm| > v0, -1 before

  double **pair_mu;                  // the pair's mu[i][j], or nullptr
  std::vector<double *> wall_mu;     // mu of each wall/mindlin/smooth fix
  bool warned;                       // the warning of init() given once

  void warn_other_setters();

  void update_mu();
  double positive_arg(const char *, const char *, bool);
};

}    // namespace LAMMPS_NS

#endif
