#include "libsph/solver/SolverSettings.h"

#include "libsph/Errors.h"

#include <cmath>
#include <sstream>

namespace cascade {

namespace {
void require(bool ok, const std::string& context, const std::string& field, const std::string& what,
             double value) {
  if (ok) return;
  std::ostringstream message;
  message << context << ": " << field << ": must be " << what << " (got " << value << ")";
  throw InputError(message.str());
}
} // namespace

void validateSettings(const SimulationSettings& s, const std::string& context) {
  require(s.fluid.spacing > 0 && std::isfinite(s.fluid.spacing), context, "fluid.spacing", "> 0", s.fluid.spacing);
  require(s.fluid.restDensity > 0, context, "fluid.density", "> 0", s.fluid.restDensity);
  require(s.fluid.viscosity >= 0, context, "fluid.viscosity", ">= 0", s.fluid.viscosity);
  require(s.solver.supportRadiusFactor == 0 || (s.solver.supportRadiusFactor >= 1 && s.solver.supportRadiusFactor <= 4),
          context, "solver.support_radius_factor", "0 (the solver's own) or in [1, 4]", s.solver.supportRadiusFactor);
  require(s.solver.stiffness >= 0, context, "solver.stiffness", ">= 0", s.solver.stiffness);
  require(s.solver.taitExponent >= 1, context, "solver.tait_exponent", ">= 1", s.solver.taitExponent);
  require(s.solver.artificialViscosity >= 0, context, "solver.artificial_viscosity", ">= 0",
          s.solver.artificialViscosity);
  require(s.solver.expectedSpeed >= 0, context, "solver.expected_speed", ">= 0", s.solver.expectedSpeed);
  require(s.solver.instabilitySpeedFactor > 1, context, "solver.instability_speed_factor", "> 1",
          s.solver.instabilitySpeedFactor);
  require(s.solver.cflFactor > 0 && s.solver.cflFactor <= 2, context, "solver.cfl", "in (0, 2]",
          s.solver.cflFactor);
  require(s.solver.minTimeStep > 0, context, "solver.min_time_step", "> 0", s.solver.minTimeStep);
  require(s.solver.maxTimeStep >= s.solver.minTimeStep, context, "solver.max_time_step",
          ">= solver.min_time_step", s.solver.maxTimeStep);
  require(s.solver.reorderInterval >= 0, context, "solver.reorder_interval", ">= 0", s.solver.reorderInterval);
  require(s.boundary.repulsionStrength >= 0, context, "boundary.repulsion_strength", ">= 0",
          s.boundary.repulsionStrength);
  require(s.boundary.repulsionRadius >= 0, context, "boundary.repulsion_radius", ">= 0",
          s.boundary.repulsionRadius);
  require(s.boundary.sampleGap > 0 && s.boundary.sampleGap <= 1, context, "boundary.sample_gap", "in (0, 1]",
          s.boundary.sampleGap);
  require(s.boundary.kappa > 0, context, "boundary.kappa", "> 0", s.boundary.kappa);
}

} // namespace cascade
