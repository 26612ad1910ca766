/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: pair style mindlin/smooth (LAMMPS plugin)

   Hertz normal force plus the smoothed Mindlin tangential force of
   Charan, Pomyalov & Procaccia, Eq. (3), with per-contact history kept
   in the per-atom arrays mindlin_partner / mindlin_t.  The pair creates
   them through its internal fix mindlin/history (no limit on contacts per
   atom), unless a fix property/atom already defines them:

     fix hist all property/atom i2_mindlin_partner 8 d2_mindlin_t 8 ghost no

   which keeps working (fixed number of slots; history in data files).
   In 3d the tangential displacement is a vector, kept in three arrays
   d2_mindlin_tx, d2_mindlin_ty, d2_mindlin_tz (instead of d2_mindlin_t),
   each with the columns of i2_mindlin_partner.
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
  void setup() override;
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
    bool listed;    // kept in the history (false: a touching pair without one)
  };

  // the same in 3d: tangential displacement vector, force, n x F_t (the
  // torque on either sphere is -R n x F_t)
  struct Contact3 {
    tagint tag;
    int listed;
    double t[3];
    double f[3], nxf[3], en;
    double del[3];
  };

  // a contact one atom computes itself, as its loop over the neighbours
  // leaves it: where its result goes (contact pos; image img, with flags)
  // and what the contact law needs
  struct Pending3 {
    int j, pos, img, flags;
    double del[3], r, gap, stored[3];
    bool band, listed;
  };

  // a contact of two owned spheres computed by the first of them in the
  // list, waiting for the second: the first's side and what the second
  // needs to check that its own side is the mirror image
  struct Image3 {
    int flags;           // HAS_CONTACT, LISTED, IN_BAND, HAS_SLOT of the first side
    double stored[3];    // the first side's stored history (zero if none)
    double t[3], f[3], nxf[3], en;
  };

  // a neighbour j of an owned sphere and its part in the pair's image
  // (pair_mindlin_smooth_3d.cpp, order_neighbors_3d)
  struct Entry3 {
    int j;
    int img;
  };

 protected:
  double **kn, **kt, **mu;
  double *maxrad;                   // largest radius of each atom type
  int ncol;                         // contact slots per atom
  int idx_partner, idx_t;           // indices of the history arrays (2d)
  int idx_t3[3];                    // 3d: mindlin_tx, mindlin_ty, mindlin_tz
  std::vector<Contact> contacts;    // scratch space, >= ncol entries
  std::vector<Contact3> contacts3;    // 3d: one atom's contacts
  std::vector<Pending3> pending3;     // 3d: those it computes itself
  std::vector<Image3> images3;        // 3d: the images of one step, in the order
                                      // they are made (compact: still in cache
                                      // when read)
  std::vector<int> near3;             // per pair of owned atoms: its image, -1 if
                                      // the pair is out of reach this step
  std::vector<Entry3> entries3;       // 3d: the neighbours of each owned atom in
  std::vector<int> first3;            // ascending tag, from first3[ii] on,
  std::vector<char> twins3;           // and whether a tag occurs twice there
  NeighList *ordered3_list;           // the list, inum and nlocal entries3
  int ordered3_inum, ordered3_nlocal;    // was made from (nullptr: none)
  class FixMindlinHistory *history;    // internal storage, or nullptr when
                                       // a fix property/atom holds the arrays
  class FixMindlinTags *tags;          // each atom's ID at the last run's start
  bool packed3;    // 3d: history slots past the first empty one are known to be zero
  bool check_rows;    // setup(): look for history entries that name distant atoms

  void allocate();
  void find_history();
  void setup_history();
  void insertion_radii();
  int grow_scratch(int);
  [[noreturn]] void too_many_contacts(tagint);
  [[noreturn]] void two_images(tagint, tagint);

  // 3d (pair_mindlin_smooth_3d.cpp)
  void compute_2d();
  void compute_3d();
  void order_neighbors_3d();
  double single_3d(int, int, int, int, double, double &);
};

}    // namespace LAMMPS_NS

#endif
