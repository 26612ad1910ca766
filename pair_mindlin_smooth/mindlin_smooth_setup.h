/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: set-up checks shared by pair mindlin/smooth and
   fix wall/mindlin/smooth.
------------------------------------------------------------------------- */

#ifndef REMOTE_TRIGGER_MINDLIN_SMOOTH_SETUP_H
#define REMOTE_TRIGGER_MINDLIN_SMOOTH_SETUP_H

#include "atom.h"
#include "domain.h"
#include "error.h"
#include "lammps.h"
#include "update.h"

#include <cstring>

namespace MindlinSmooth {

// Both styles need atom style sphere (disks in 2d, spheres in 3d).
// `what` names the command in the error, e.g. "Pair style mindlin/smooth".
inline void require_spheres(LAMMPS_NS::LAMMPS *lmp, const char *what)
{
  if (!lmp->atom->radius_flag || !lmp->atom->omega_flag || !lmp->atom->torque_flag)
    lmp->error->all(FLERR, "{} requires atom style sphere", what);
}

// The contact law has no rolling or twisting resistance (relative rolling
// and spin about the normal cost nothing).  A deck that asks for them, with
// the keywords of pair granular, is told so instead of "wrong number of
// arguments".
inline void refuse_rolling_twisting(LAMMPS_NS::LAMMPS *lmp, const char *what, int narg,
                                    char **arg)
{
  for (int i = 0; i < narg; i++)
    if (strcmp(arg[i], "rolling") == 0 || strcmp(arg[i], "twisting") == 0)
      lmp->error->all(FLERR,
                      "{}: the contact law has no {} resistance (got '{}'); pair granular "
                      "offers rolling and twisting models",
                      what, arg[i], arg[i]);
}

// The tangential displacement is advanced by the velocities of each MD step
// (v dt is the step's displacement); an energy minimization moves atoms
// without meaningful velocities, so it would corrupt the history. Refuse it
// unless the contacts are frictionless (every mu or k_t zero: no tangential
// force, the history stays zero), where a minimizer finds the same
// equilibria as damped dynamics.
inline void forbid_minimize(LAMMPS_NS::LAMMPS *lmp, const char *what, bool frictionless)
{
  if (lmp->update->whichflag == 2 && !frictionless)
    lmp->error->all(FLERR,
                    "{} cannot be used with minimize unless mu = 0 (frictionless): the "
                    "contact history follows the dynamics; relax with damped dynamics instead",
                    what);
}

}    // namespace MindlinSmooth

#endif
