#pragma once
// The simulated magnetic field at any 3-D point (µT): Earth's main field, a smooth background of
// a few µT, the anomalies of structural steel as exact point dipoles, and the floor's
// reinforcement mesh as the magnetic charges at its bar ends.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "mm4mm/sim/simulation_config.hpp"
#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

/// Field of a point dipole with moment `moment_Am2` at offset `r_m` from it, in µT:
/// B = μ0/(4π) · (3 r̂ (r̂·m) − m) / |r|³, with μ0/(4π) = 1e-7 T·m/A = 0.1 µT·m/A.
Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& r_m);

/// Field of a magnetic point charge `charge_Am` at offset `r_m` from it, in µT:
/// B = μ0/(4π) · q r̂ / |r|².
Eigen::Vector3d chargeField(double charge_Am, const Eigen::Vector3d& r_m);

/// Unit vector of the Earth's field in the world frame (z up, so the dip points to -z).
Eigen::Vector3d earthFieldDirection(const EarthFieldConfig& earth);

class MagneticFieldModel {
 public:
  /// The background's wave vectors and phases are drawn from `seed`. Sources farther than their
  /// cutoff radius from a query point are left out.
  MagneticFieldModel(const EarthFieldConfig& earth, const BackgroundFieldConfig& background,
                     const std::vector<MagneticDipole>& dipoles, double dipole_cutoff_radius_m,
                     const std::vector<MagneticCharge>& charges, double charge_cutoff_radius_m,
                     std::uint64_t seed);

  /// Total field at `point_world` (m), in µT, world axes.
  Eigen::Vector3d fieldAt(const Eigen::Vector3d& point_world) const;

  Eigen::Vector3d earthField() const { return earth_uT_; }
  /// Smooth background alone: B = −∇φ of harmonic potentials φ = A cos(k·x + ψ) e^{−|k| z}.
  Eigen::Vector3d backgroundAt(const Eigen::Vector3d& point_world) const;
  /// Sum of the steel dipoles within the cutoff radius.
  Eigen::Vector3d anomalyAt(const Eigen::Vector3d& point_world) const;
  /// Sum of the floor mesh's charges within their cutoff radius.
  Eigen::Vector3d floorMeshAt(const Eigen::Vector3d& point_world) const;

 private:
  struct Wave {
    Eigen::Vector2d k;  ///< rad/m
    double amplitude_uT_m = 0.0;
    double phase = 0.0;
  };
  // Point sources sorted by plan cell into flat arrays (cell c holds [cell_start[c],
  // cell_start[c+1])) so a query visits only nearby cells and its inner loop runs over contiguous
  // memory. Dipoles use all three strengths, charges only sx.
  struct SourceGrid {
    double cutoff_radius_m = 0.0;
    double cell_size_m = 2.0;
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    int nx = 0, ny = 0;
    std::vector<int> cell_start;
    std::vector<double> px, py, pz, sx, sy, sz;

    void build(std::vector<Eigen::Vector3d> positions, std::vector<Eigen::Vector3d> strengths,
               double cutoff_radius_m);
    template <typename Visit>
    void visitNear(const Eigen::Vector3d& p, Visit&& visit) const;
  };

  Eigen::Vector3d earth_uT_;
  std::vector<Wave> waves_;
  SourceGrid dipoles_;
  SourceGrid charges_;
};

}  // namespace mm4mm::sim
