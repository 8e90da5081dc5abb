#pragma once
// Particle Swarm Optimization (Kennedy & Eberhart 1995, with inertia weight), as the paper uses
// for magnetic data association (Section III-B.1a). Box-bounded, seeded, maximising.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>

namespace mm4mm {

struct PsoConfig {
  int particles = 32;
  int iterations = 60;
  double inertia = 0.7298;              ///< Clerc–Kennedy constriction values
  double cognitive = 1.4962;            ///< pull towards a particle's own best
  double social = 1.4962;               ///< pull towards the swarm's best
  double max_velocity_fraction = 0.25;  ///< of the box size, per dimension and step
  /// Stops when the best value improved by less than this over `stall_iterations` iterations.
  double tolerance = 1e-6;
  int stall_iterations = 12;
  std::uint64_t seed = 1;

  bool IsValid(std::string* error) const;
};

struct PsoResult {
  Eigen::VectorXd best;
  double value = 0.0;
  int evaluations = 0;
  int iterations = 0;
  bool converged = false;  ///< stopped by the stall rule rather than the iteration limit
};

/// Maximises `objective` over the box [lower, upper]. When `initial` is given, one particle
/// starts there. Particles are evaluated in parallel; the result does not depend on threads.
PsoResult psoMaximize(const std::function<double(const Eigen::VectorXd&)>& objective,
                      const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                      const PsoConfig& config, const Eigen::VectorXd* initial = nullptr);

}  // namespace mm4mm
