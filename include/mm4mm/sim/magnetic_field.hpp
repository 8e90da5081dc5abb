#pragma once
// The simulated magnetic field at any 3-D point (µT): Earth's main field, a smooth background of
// a few µT, and the anomalies of structural steel as exact point dipoles.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "mm4mm/sim/simulation_config.hpp"
#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

/// Field of a point dipole with moment `moment_Am2` at offset `r_m` from it, in µT:
/// B = μ0/(4π) · (3 r̂ (r̂·m) − m) / |r|³, with μ0/(4π) = 1e-7 T·m/A = 0.1 µT·m/A.
Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& r_m);

/// Unit vector of the Earth's field in the world frame (z up, so the dip points to -z).
Eigen::Vector3d earthFieldDirection(const EarthFieldConfig& earth);

class MagneticFieldModel {
 public:
  /// The background's wave vectors and phases are drawn from `seed`.
  MagneticFieldModel(const EarthFieldConfig& earth, const BackgroundFieldConfig& background,
                     std::vector<MagneticDipole> dipoles, double cutoff_radius_m,
                     std::uint64_t seed);

  /// Total field at `point_world` (m), in µT, world axes.
  Eigen::Vector3d fieldAt(const Eigen::Vector3d& point_world) const;

  Eigen::Vector3d earthField() const { return earth_uT_; }
  /// Smooth background alone: B = −∇φ of harmonic potentials φ = A cos(k·x + ψ) e^{−|k| z}.
  Eigen::Vector3d backgroundAt(const Eigen::Vector3d& point_world) const;
  /// Sum of the steel dipoles within the cutoff radius.
  Eigen::Vector3d anomalyAt(const Eigen::Vector3d& point_world) const;

 private:
  struct Wave {
    Eigen::Vector2d k;  ///< rad/m
    double amplitude_uT_m = 0.0;
    double phase = 0.0;
  };

  Eigen::Vector3d earth_uT_;
  std::vector<Wave> waves_;
  double cutoff_radius_m_;
  // Dipoles sorted by plan cell into flat arrays (cell c holds [cell_start_[c], cell_start_[c+1]))
  // so a query visits only nearby cells and its inner loop runs over contiguous memory.
  double cell_size_m_;
  Eigen::Vector2d grid_origin_ = Eigen::Vector2d::Zero();
  int grid_nx_ = 0, grid_ny_ = 0;
  std::vector<int> cell_start_;
  std::vector<double> px_, py_, pz_, mx_, my_, mz_;
};

}  // namespace mm4mm::sim
