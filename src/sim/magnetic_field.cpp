#include "mm4mm/sim/magnetic_field.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace mm4mm::sim {
namespace {

constexpr double kMu0Over4Pi_uT_m_per_A = 0.1;

}  // namespace

Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& r_m) {
  const double r = r_m.norm();
  const Eigen::Vector3d r_hat = r_m / r;
  return kMu0Over4Pi_uT_m_per_A * (3.0 * r_hat * r_hat.dot(moment_Am2) - moment_Am2) / (r * r * r);
}

Eigen::Vector3d chargeField(double charge_Am, const Eigen::Vector3d& r_m) {
  const double r = r_m.norm();
  return kMu0Over4Pi_uT_m_per_A * charge_Am * r_m / (r * r * r);
}

Eigen::Vector3d earthFieldDirection(const EarthFieldConfig& earth) {
  const double inclination = earth.inclination_deg * M_PI / 180.0;
  const double declination = earth.declination_deg * M_PI / 180.0;
  return {std::cos(inclination) * std::cos(declination),
          std::cos(inclination) * std::sin(declination), -std::sin(inclination)};
}

void MagneticFieldModel::SourceGrid::build(std::vector<Eigen::Vector3d> positions,
                                           std::vector<Eigen::Vector3d> strengths,
                                           double cutoff_radius) {
  cutoff_radius_m = cutoff_radius;
  // Cells of a few metres keep the visited area close to the cutoff disc at either scale.
  cell_size_m = std::clamp(0.25 * cutoff_radius, 1.0, 2.0);
  Eigen::AlignedBox2d bounds;
  for (const auto& p : positions) bounds.extend(p.head<2>());
  if (bounds.isEmpty()) return;
  origin = bounds.min();
  nx = static_cast<int>(bounds.sizes().x() / cell_size_m) + 1;
  ny = static_cast<int>(bounds.sizes().y() / cell_size_m) + 1;
  const auto cell_of = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d c = (p.head<2>() - origin) / cell_size_m;
    return std::min(static_cast<int>(c.y()), ny - 1) * nx + std::min(static_cast<int>(c.x()), nx - 1);
  };
  std::vector<std::size_t> order(positions.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return cell_of(positions[a]) < cell_of(positions[b]);
  });
  cell_start.assign(static_cast<std::size_t>(nx) * ny + 1, 0);
  for (const auto& p : positions) ++cell_start[cell_of(p) + 1];
  for (std::size_t c = 1; c < cell_start.size(); ++c) cell_start[c] += cell_start[c - 1];
  for (std::size_t i : order) {
    px.push_back(positions[i].x()), py.push_back(positions[i].y()), pz.push_back(positions[i].z());
    sx.push_back(strengths[i].x()), sy.push_back(strengths[i].y()), sz.push_back(strengths[i].z());
  }
}

template <typename Visit>
void MagneticFieldModel::SourceGrid::visitNear(const Eigen::Vector3d& p, Visit&& visit) const {
  if (cell_start.empty()) return;
  const Eigen::Vector2d lo = (p.head<2>() - origin).array() - cutoff_radius_m;
  const Eigen::Vector2d hi = (p.head<2>() - origin).array() + cutoff_radius_m;
  const int x0 = std::max(0, static_cast<int>(std::floor(lo.x() / cell_size_m)));
  const int y0 = std::max(0, static_cast<int>(std::floor(lo.y() / cell_size_m)));
  const int x1 = std::min(nx - 1, static_cast<int>(std::floor(hi.x() / cell_size_m)));
  const int y1 = std::min(ny - 1, static_cast<int>(std::floor(hi.y() / cell_size_m)));
  const double cutoff_squared = cutoff_radius_m * cutoff_radius_m;
  for (int cy = y0; cy <= y1; ++cy) {
    // Cells of one grid row are contiguous in the sorted arrays.
    const int begin = cell_start[cy * nx + x0];
    const int end = cell_start[cy * nx + x1 + 1];
    for (int i = begin; i < end; ++i) {
      const double rx = p.x() - px[i], ry = p.y() - py[i], rz = p.z() - pz[i];
      const double r2 = rx * rx + ry * ry + rz * rz;
      if (r2 > cutoff_squared || r2 < 1e-12) continue;
      visit(i, rx, ry, rz, r2);
    }
  }
}

MagneticFieldModel::MagneticFieldModel(const EarthFieldConfig& earth,
                                       const BackgroundFieldConfig& background,
                                       const std::vector<MagneticDipole>& dipoles,
                                       double dipole_cutoff_radius_m,
                                       const std::vector<MagneticCharge>& charges,
                                       double charge_cutoff_radius_m, std::uint64_t seed)
    : earth_uT_(earth.magnitude_uT * earthFieldDirection(earth)) {
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
  std::vector<Eigen::Vector3d> positions, strengths;
  for (const auto& d : dipoles) positions.push_back(d.position_m), strengths.push_back(d.moment_Am2);
  dipoles_.build(std::move(positions), std::move(strengths), dipole_cutoff_radius_m);
  positions.clear(), strengths.clear();
  for (const auto& c : charges)
    positions.push_back(c.position_m), strengths.emplace_back(c.charge_Am, 0.0, 0.0);
  charges_.build(std::move(positions), std::move(strengths), charge_cutoff_radius_m);
}

Eigen::Vector3d MagneticFieldModel::fieldAt(const Eigen::Vector3d& point_world) const {
  return earth_uT_ + backgroundAt(point_world) + anomalyAt(point_world) + floorMeshAt(point_world);
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
  double bx = 0.0, by = 0.0, bz = 0.0;
  const SourceGrid& g = dipoles_;
  g.visitNear(p, [&](int i, double rx, double ry, double rz, double r2) {
    // dipoleField() written out over the flat arrays.
    const double inv_r2 = 1.0 / r2;
    const double inv_r3 = inv_r2 / std::sqrt(r2);
    const double k = 3.0 * (g.sx[i] * rx + g.sy[i] * ry + g.sz[i] * rz) * inv_r2;
    bx += (k * rx - g.sx[i]) * inv_r3;
    by += (k * ry - g.sy[i]) * inv_r3;
    bz += (k * rz - g.sz[i]) * inv_r3;
  });
  return kMu0Over4Pi_uT_m_per_A * Eigen::Vector3d(bx, by, bz);
}

Eigen::Vector3d MagneticFieldModel::floorMeshAt(const Eigen::Vector3d& p) const {
  double bx = 0.0, by = 0.0, bz = 0.0;
  const SourceGrid& g = charges_;
  g.visitNear(p, [&](int i, double rx, double ry, double rz, double r2) {
    const double q_over_r3 = g.sx[i] / (r2 * std::sqrt(r2));
    bx += q_over_r3 * rx;
    by += q_over_r3 * ry;
    bz += q_over_r3 * rz;
  });
  return kMu0Over4Pi_uT_m_per_A * Eigen::Vector3d(bx, by, bz);
}

}  // namespace mm4mm::sim
