#include "mm4mm/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "random_draws.hpp"
#include "world_builders.hpp"

namespace mm4mm::sim {
namespace {

// Sub-streams of the world seed (the steel members' moments use the seed itself).
constexpr std::uint64_t kFloorSteelStream = 11;
constexpr std::uint64_t kFloorMeshStream = 12;
constexpr std::uint64_t kGeometryStream = 13;

// Half the width a lane must keep free: the rig's magnetometer row plus a margin, so that no
// sensor passes through a wall's steel.
double laneClearance(const RigConfig& rig) {
  return 0.5 * (rig.magnetometer_count - 1) * rig.magnetometer_spacing_m + 0.4;
}

}  // namespace

Eigen::AlignedBox2d Solid::planBounds() const {
  Eigen::AlignedBox2d box;
  for (const auto& v : polygon) box.extend(v);
  return box;
}

bool Solid::contains(const Eigen::Vector3d& point) const {
  if (point.z() < z_min_m || point.z() > z_max_m) return false;
  return planDistance(point.head<2>()) == 0.0;
}

double Solid::planDistance(const Eigen::Vector2d& point) const {
  bool inside = true;
  double best = std::numeric_limits<double>::infinity();
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + 1) % n];
    const Eigen::Vector2d edge = b - a;
    // Counter-clockwise polygon: the interior is to the left of every edge.
    if (edge.x() * (point.y() - a.y()) - edge.y() * (point.x() - a.x()) < 0.0) inside = false;
    const double s = std::clamp((point - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + s * edge - point).norm());
  }
  return inside ? 0.0 : best;
}

double Solid::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double t_min, double t_max) const {
  // Clip the ray's parameter interval by the two z planes and each edge's half-plane; the
  // convex solid is their intersection, so the interval's start is the entry point.
  double enter = t_min;
  double leave = t_max;
  const auto clip = [&](double numerator, double denominator) {
    // Half-space: denominator * t <= numerator.
    if (std::abs(denominator) < 1e-15) return numerator >= 0.0;
    const double t = numerator / denominator;
    if (denominator > 0.0)
      leave = std::min(leave, t);
    else
      enter = std::max(enter, t);
    return enter <= leave;
  };
  if (!clip(z_max_m - origin.z(), direction.z())) return -1.0;
  if (!clip(origin.z() - z_min_m, -direction.z())) return -1.0;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d edge = polygon[(i + 1) % n] - a;
    const Eigen::Vector2d outward(edge.y(), -edge.x());
    const double numerator = outward.dot(a) - outward.dot(origin.head<2>());
    if (!clip(numerator, outward.dot(direction.head<2>()))) return -1.0;
  }
  return enter;
}

Solid boxSolid(const Eigen::Vector2d& min_xy, const Eigen::Vector2d& max_xy, double z_min_m,
               double z_max_m) {
  Solid solid;
  solid.polygon = {min_xy, {max_xy.x(), min_xy.y()}, max_xy, {min_xy.x(), max_xy.y()}};
  solid.z_min_m = z_min_m;
  solid.z_max_m = z_max_m;
  return solid;
}

Solid regularPrism(const Eigen::Vector2d& centre, double radius_m, int sides, double z_min_m,
                   double z_max_m) {
  Solid solid;
  for (int i = 0; i < sides; ++i) {
    const double angle = (2.0 * M_PI * i) / sides + M_PI / sides;
    solid.polygon.push_back(centre + radius_m * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
  }
  solid.z_min_m = z_min_m;
  solid.z_max_m = z_max_m;
  return solid;
}

int LaneGraph::addNode(const Eigen::Vector2d& position) {
  nodes.push_back(position);
  neighbours.emplace_back();
  return static_cast<int>(nodes.size()) - 1;
}

void LaneGraph::connect(int a, int b) {
  neighbours.at(a).push_back(b);
  neighbours.at(b).push_back(a);
}

std::vector<MagneticDipole> placeSteelDipoles(const SteelAnchors& anchors,
                                              const SimulationConfig& config, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d induced_direction = earthFieldDirection(config.earth);
  const SteelConfig& steel = config.steel;
  std::vector<MagneticDipole> dipoles;
  for (const SteelMember& member : anchors) {
    double induced = steel.pillar_induced_moment_Am2, remanent = steel.pillar_remanent_moment_Am2;
    if (member.kind == SteelKind::kUpright)
      induced = steel.upright_induced_moment_Am2, remanent = steel.upright_remanent_moment_Am2;
    if (member.kind == SteelKind::kBeam)
      induced = steel.beam_induced_moment_Am2, remanent = steel.beam_remanent_moment_Am2;
    if (member.kind == SteelKind::kObject)
      induced = member.induced_moment_Am2, remanent = member.remanent_moment_Am2;
    // A member's remanent magnetisation comes from its own history: one draw per member.
    const Eigen::Vector3d moment = induced * induced_direction + remanent * drawVector3(gauss, rng);
    const double length = (member.to_m - member.from_m).norm();
    const int count =
        std::max(1, static_cast<int>(std::round(length / steel.dipole_spacing_m)) + 1);
    for (int i = 0; i < count; ++i) {
      const double s = count > 1 ? static_cast<double>(i) / (count - 1) : 0.5;
      const double jitter = 1.0 + steel.moment_jitter * gauss(rng);
      dipoles.push_back({member.from_m + s * (member.to_m - member.from_m), jitter * moment});
    }
  }
  return dipoles;
}

std::vector<MagneticCharge> floorMeshCharges(const Eigen::AlignedBox2d& floor,
                                             const SimulationConfig& config, std::uint64_t seed) {
  const FloorMeshConfig& mesh = config.floor_mesh;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> placement(-0.05, 0.05);  // sheets laid by hand
  // H = B / μ0 in A/m for B in µT.
  const Eigen::Vector3d earth_H_A_per_m =
      config.earth.magnitude_uT * earthFieldDirection(config.earth) / (4.0 * M_PI * 0.1);
  const double area_m2 = 0.25 * M_PI * mesh.bar_diameter_m * mesh.bar_diameter_m;
  const double z = -mesh.depth_m;
  std::vector<MagneticCharge> charges;
  // One bar from `from` to `to`: magnetisation along it, ending in charges -q at from, +q at to.
  const auto add_bar = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
    const Eigen::Vector2d along = (to - from).normalized();
    const double induced = mesh.susceptibility * earth_H_A_per_m.head<2>().dot(along);
    const double q = (induced + mesh.remanent_magnetisation_A_per_m * gauss(rng)) * area_m2;
    charges.push_back({Eigen::Vector3d(from.x(), from.y(), z), -q});
    charges.push_back({Eigen::Vector3d(to.x(), to.y(), z), q});
  };
  const double pitch_x = mesh.sheet_length_m - mesh.lap_m;
  const double pitch_y = mesh.sheet_width_m - mesh.lap_m;
  for (double y0 = floor.min().y(); y0 < floor.max().y(); y0 += pitch_y)
    for (double x0 = floor.min().x(); x0 < floor.max().x(); x0 += pitch_x) {
      const double dy = placement(rng);
      const double dx = placement(rng);
      const Eigen::Vector2d origin(x0 + dx, y0 + dy);
      const Eigen::Vector2d length(std::min(mesh.sheet_length_m, floor.max().x() - origin.x()),
                                   std::min(mesh.sheet_width_m, floor.max().y() - origin.y()));
      if (length.x() <= mesh.bar_spacing_m || length.y() <= mesh.bar_spacing_m) continue;
      for (double v = 0.5 * mesh.bar_spacing_m; v < length.y(); v += mesh.bar_spacing_m)
        add_bar(origin + Eigen::Vector2d(0.0, v), origin + Eigen::Vector2d(length.x(), v));
      for (double u = 0.5 * mesh.bar_spacing_m; u < length.x(); u += mesh.bar_spacing_m)
        add_bar(origin + Eigen::Vector2d(u, 0.0), origin + Eigen::Vector2d(u, length.y()));
    }
  return charges;
}

std::vector<MagneticDipole> floorSteelDipoles(const Eigen::AlignedBox2d& floor,
                                              const FloorSteelConfig& config, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> x(floor.min().x(), floor.max().x());
  std::uniform_real_distribution<double> y(floor.min().y(), floor.max().y());
  std::uniform_real_distribution<double> depth(config.min_depth_m, config.max_depth_m);
  const auto count = static_cast<std::size_t>(std::lround(config.density_per_m2 * floor.volume()));
  std::vector<MagneticDipole> dipoles;
  for (std::size_t i = 0; i < count; ++i) {
    MagneticDipole d;
    const double px = x(rng);
    const double py = y(rng);
    d.position_m = Eigen::Vector3d(px, py, -depth(rng));
    d.moment_Am2 = config.moment_Am2 * drawVector3(gauss, rng);
    dipoles.push_back(d);
  }
  return dipoles;
}

std::optional<Eigen::Vector2d> World::degenerateAxisAt(const Eigen::Vector2d& position) const {
  for (const DegenerateRegion& region : degenerate_regions)
    if (region.area.contains(position)) return region.axis;
  return std::nullopt;
}

void addEnclosingWalls(World* world, double thickness_m) {
  const Eigen::Vector2d lo = world->floor_xy.min();
  const Eigen::Vector2d hi = world->floor_xy.max();
  const double t = thickness_m;
  const double h = world->ceiling_height_m;
  world->solids.push_back(boxSolid({lo.x() - t, lo.y() - t}, {hi.x() + t, lo.y()}, 0.0, h));
  world->solids.push_back(boxSolid({lo.x() - t, hi.y()}, {hi.x() + t, hi.y() + t}, 0.0, h));
  world->solids.push_back(boxSolid({lo.x() - t, lo.y()}, {lo.x(), hi.y()}, 0.0, h));
  world->solids.push_back(boxSolid({hi.x(), lo.y()}, {hi.x() + t, hi.y()}, 0.0, h));
}

LaneGraph gridLanes(const std::vector<double>& xs, const std::vector<double>& ys) {
  LaneGraph lanes;
  std::vector<std::vector<int>> id(xs.size(), std::vector<int>(ys.size()));
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (std::size_t j = 0; j < ys.size(); ++j) id[i][j] = lanes.addNode({xs[i], ys[j]});
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (std::size_t j = 0; j < ys.size(); ++j) {
      if (i + 1 < xs.size()) lanes.connect(id[i][j], id[i + 1][j]);
      if (j + 1 < ys.size()) lanes.connect(id[i][j], id[i][j + 1]);
    }
  return lanes;
}

World buildWorld(const SimulationConfig& config, std::uint64_t seed) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("simulation config: " + error);
  SteelAnchors anchors;
  // A procedural building may draw its own floor steel: the rest reads this copy.
  SimulationConfig drawn = config;
  World world;
  if (config.world == "corridor")
    world = buildCorridor(config.corridor, &anchors);
  else if (config.world == "procedural")
    world = buildProcedural(&drawn, laneClearance(config.rig), deriveSeed(seed, kGeometryStream),
                            &anchors);
  else
    world = buildWarehouse(config.warehouse, &anchors);
  world.dipoles = placeSteelDipoles(anchors, drawn, seed);
  const std::vector<MagneticDipole> floor_steel =
      floorSteelDipoles(world.floor_xy, drawn.floor_steel, deriveSeed(seed, kFloorSteelStream));
  world.dipoles.insert(world.dipoles.end(), floor_steel.begin(), floor_steel.end());
  if (drawn.floor_mesh.enabled)
    world.charges = floorMeshCharges(world.floor_xy, drawn, deriveSeed(seed, kFloorMeshStream));
  return world;
}

}  // namespace mm4mm::sim
