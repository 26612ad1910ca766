/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: fix addforce/oscillating (LAMMPS plugin)

   fix ID group addforce/oscillating Fx Fy Fz a omega [onset T]

   Adds to every atom of the group the force (Fx + f(t), Fy, Fz) with

     f(t) = a e(t) cos(omega t),
     e(t) = (1 - cos(pi t/T))/2 for t < T, 1 after (T = 0: e = 1),

   t the simulation time ('time' of thermo and variables): the load F_x
   with the forcing of Fig. 5 of Charan, Pomyalov & Procaccia.  One
   cosine per step instead of a per-atom variable.
------------------------------------------------------------------------- */

#ifndef LMP_FIX_ADDFORCE_OSCILLATING_H
#define LMP_FIX_ADDFORCE_OSCILLATING_H

#include "fix.h"

namespace LAMMPS_NS {

class FixAddForceOscillating : public Fix {
 public:
  FixAddForceOscillating(class LAMMPS *, int, char **);

  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_vector(int) override;

 protected:
  double fx, fy, fz;    // constant part
  double amp, omega;    // a, omega of f(t)
  double onset;         // T of the raised-cosine onset, 0 = step

  double forcing(double, double &) const;
  double now() const;
  double number(const char *, const char *);
};

}    // namespace LAMMPS_NS

#endif
