#include "mm4mm/sim/magnetic_field.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace mm4mm::sim {

Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& r_m) {
  constexpr double kMu0Over4Pi_uT_m_per_A = 0.1;
  const double r = r_m.norm();
  const Eigen::Vector3d r_hat = r_m / r;
  return kMu0Over4Pi_uT_m_per_A * (3.0 * r_hat * r_hat.dot(moment_Am2) - moment_Am2) / (r * r * r);
}

Eigen::Vector3d earthFieldDirection(const EarthFieldConfig& earth) {
  const double inclination = earth.inclination_deg * M_PI / 180.0;
  const double declination = earth.declination_deg * M_PI / 180.0;
  return {std::cos(inclination) * std::cos(declination),
          std::cos(inclination) * std::sin(declination), -std::sin(inclination)};
}

MagneticFieldModel::MagneticFieldModel(const EarthFieldConfig& earth,
                                       const BackgroundFieldConfig& background,
                                       std::vector<MagneticDipole> dipoles, double cutoff_radius_m,
                                       std::uint64_t seed)
    : earth_uT_(earth.magnitude_uT * earthFieldDirection(earth)),
      cutoff_radius_m_(cutoff_radius_m),
      cell_size_m_(2.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int i = 0; i < background.components; ++i) {
    // Wavelengths log-uniform between the bounds, directions uniform.
    const double wavelength =
        background.min_wavelength_m *
        std::pow(background.max_wavelength_m / background.min_wavelength_m, unit(rng));
    const double heading = 2.0 * M_PI * unit(rng);
    Wave wave;
    wave.k = (2.0 * M_PI / wavelength) * Eigen::Vector2d(std::cos(heading), std::sin(heading));
    // |B| of one component is A·|k| at z = 0; choose A so that equals the configured amplitude.
    wave.amplitude_uT_m = background.amplitude_uT * gauss(rng) / wave.k.norm();
    wave.phase = 2.0 * M_PI * unit(rng);
    waves_.push_back(wave);
  }

  Eigen::AlignedBox2d bounds;
  for (const auto& d : dipoles) bounds.extend(d.position_m.head<2>());
  if (bounds.isEmpty()) return;
  grid_origin_ = bounds.min();
  grid_nx_ = static_cast<int>(bounds.sizes().x() / cell_size_m_) + 1;
  grid_ny_ = static_cast<int>(bounds.sizes().y() / cell_size_m_) + 1;
  const auto cell_of = [&](const MagneticDipole& d) {
    const Eigen::Vector2d c = (d.position_m.head<2>() - grid_origin_) / cell_size_m_;
    return std::min(static_cast<int>(c.y()), grid_ny_ - 1) * grid_nx_ +
           std::min(static_cast<int>(c.x()), grid_nx_ - 1);
  };
  std::stable_sort(dipoles.begin(), dipoles.end(),
                   [&](const auto& a, const auto& b) { return cell_of(a) < cell_of(b); });
  cell_start_.assign(static_cast<std::size_t>(grid_nx_) * grid_ny_ + 1, 0);
  for (const auto& d : dipoles) ++cell_start_[cell_of(d) + 1];
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  for (const auto& d : dipoles) {
    px_.push_back(d.position_m.x()), py_.push_back(d.position_m.y()),
        pz_.push_back(d.position_m.z());
    mx_.push_back(d.moment_Am2.x()), my_.push_back(d.moment_Am2.y()),
        mz_.push_back(d.moment_Am2.z());
  }
}

Eigen::Vector3d MagneticFieldModel::fieldAt(const Eigen::Vector3d& point_world) const {
  return earth_uT_ + backgroundAt(point_world) + anomalyAt(point_world);
}

Eigen::Vector3d MagneticFieldModel::backgroundAt(const Eigen::Vector3d& p) const {
  Eigen::Vector3d field = Eigen::Vector3d::Zero();
  for (const Wave& w : waves_) {
    const double k = w.k.norm();
    const double decay = std::exp(-k * p.z());
    const double arg = w.k.dot(p.head<2>()) + w.phase;
    // φ = A cos(arg) e^{−kz}; B = −∇φ.
    field.x() += w.amplitude_uT_m * w.k.x() * std::sin(arg) * decay;
    field.y() += w.amplitude_uT_m * w.k.y() * std::sin(arg) * decay;
    field.z() += w.amplitude_uT_m * k * std::cos(arg) * decay;
  }
  return field;
}

Eigen::Vector3d MagneticFieldModel::anomalyAt(const Eigen::Vector3d& p) const {
  if (cell_start_.empty()) return Eigen::Vector3d::Zero();
  const Eigen::Vector2d lo = (p.head<2>() - grid_origin_).array() - cutoff_radius_m_;
  const Eigen::Vector2d hi = (p.head<2>() - grid_origin_).array() + cutoff_radius_m_;
  const int x0 = std::max(0, static_cast<int>(std::floor(lo.x() / cell_size_m_)));
  const int y0 = std::max(0, static_cast<int>(std::floor(lo.y() / cell_size_m_)));
  const int x1 = std::min(grid_nx_ - 1, static_cast<int>(std::floor(hi.x() / cell_size_m_)));
  const int y1 = std::min(grid_ny_ - 1, static_cast<int>(std::floor(hi.y() / cell_size_m_)));
  const double cutoff_squared = cutoff_radius_m_ * cutoff_radius_m_;
  constexpr double kMu0Over4Pi_uT_m_per_A = 0.1;
  double bx = 0.0, by = 0.0, bz = 0.0;
  for (int cy = y0; cy <= y1; ++cy) {
    // Cells of one grid row are contiguous in the sorted arrays.
    const int begin = cell_start_[cy * grid_nx_ + x0];
    const int end = cell_start_[cy * grid_nx_ + x1 + 1];
    for (int i = begin; i < end; ++i) {
      // dipoleField() written out over the flat arrays.
      const double rx = p.x() - px_[i], ry = p.y() - py_[i], rz = p.z() - pz_[i];
      const double r2 = rx * rx + ry * ry + rz * rz;
      if (r2 > cutoff_squared || r2 < 1e-12) continue;
      const double inv_r2 = 1.0 / r2;
      const double inv_r3 = inv_r2 / std::sqrt(r2);
      const double m_dot_r = mx_[i] * rx + my_[i] * ry + mz_[i] * rz;
      const double k = 3.0 * m_dot_r * inv_r2;
      bx += (k * rx - mx_[i]) * inv_r3;
      by += (k * ry - my_[i]) * inv_r3;
      bz += (k * rz - mz_[i]) * inv_r3;
    }
  }
  return kMu0Over4Pi_uT_m_per_A * Eigen::Vector3d(bx, by, bz);
}

}  // namespace mm4mm::sim
