/* -*- c++ -*- ----------------------------------------------------------
   remote-trigger: set-up checks shared by pair mindlin/smooth and the
   plugin's fixes.
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

// The fixes act in post_force / pre_force of velocity Verlet; under
// run_style respa those hooks are not called and the fix would silently do
// nothing (the wall vanished), so a respa run is refused.
inline void forbid_respa(LAMMPS_NS::LAMMPS *lmp, const char *what)
{
  if (lmp->update->integrate_style && strncmp(lmp->update->integrate_style, "respa", 5) == 0)
    lmp->error->all(FLERR, "{} does not support run_style respa; use run_style verlet", what);
}

// The contact history names each partner by its atom ID (0 marks an empty
// slot), so atoms must have IDs.
inline void require_atom_ids(LAMMPS_NS::LAMMPS *lmp, const char *what)
{
  if (!lmp->atom->tag_enable)
    lmp->error->all(FLERR,
                    "{} requires atom IDs (the contact history names partners by ID): do not "
                    "use 'atom_modify id no'",
                    what);
}

}    // namespace MindlinSmooth

#endif
