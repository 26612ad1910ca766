/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin)

   Hertz normal force plus the smoothed Mindlin tangential force of
   Charan, Pomyalov & Procaccia, Eq. (3), with per-contact history kept
   in per-atom arrays of a fix property/atom:

     fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 ghost no
------------------------------------------------------------------------- */

#ifndef LMP_PAIR_MINDLIN_SMOOTH_H
#define LMP_PAIR_MINDLIN_SMOOTH_H

#include "pair.h"

#include <vector>

namespace LAMMPS_NS {

class PairMindlinSmooth : public Pair {
 public:
  PairMindlinSmooth(class LAMMPS *);
  ~PairMindlinSmooth() override;

  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  double single(int, int, int, int, double, double, double, double &) override;
  void *extract(const char *, int &) override;

  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_restart_settings(FILE *) override {}
  void read_restart_settings(FILE *) override {}
  void write_data(FILE *) override;
  void write_data_all(FILE *) override;

  // one contact of the atom being processed, before it is summed
  struct Contact {
    tagint tag;    // partner atom ID
    double xi;     // tangential displacement after the Coulomb cap
    double fx, fy, tz, en;
    double delx, dely;
  };

 protected:
  double **kn, **kt, **mu;
  double *maxrad;                   // largest radius of each atom type
  int ncol;                         // contact slots per atom
  int idx_partner, idx_t;           // indices of the history arrays
  std::vector<Contact> contacts;    // scratch space, ncol entries

  void allocate();
  void find_history();
};

}    // namespace LAMMPS_NS

#endif
