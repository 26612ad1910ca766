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

namespace MindlinSmooth {

// Both styles need disks: atom style sphere in a 2d simulation.
// `what` names the command in the error, e.g. "Pair style mindlin/smooth".
inline void require_2d_spheres(LAMMPS_NS::LAMMPS *lmp, const char *what)
{
  if (!lmp->atom->radius_flag || !lmp->atom->omega_flag || !lmp->atom->torque_flag)
    lmp->error->all(FLERR, "{} requires atom style sphere", what);
  if (lmp->domain->dimension != 2)
    lmp->error->all(FLERR,
                    "{} supports 2d simulations only (dimension 2), this one has dimension {}",
                    what, lmp->domain->dimension);
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
