#pragma once
// Continuous planar motion along a route at constant speed: straight lines, circular arcs at
// gentle corners, turns in place at sharp ones. Plus small roll/pitch jitter of a wheeled base.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "mm4mm/sim/route.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

struct PlanarState {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< world (m)
  double yaw_rad = 0.0;
  double distance_m = 0.0;  ///< travelled since the start
};

class PlanarTrajectory {
 public:
  PlanarTrajectory(const Route& route, const MotionConfig& motion);

  double duration() const { return duration_s_; }
  PlanarState at(double time_s) const;

 private:
  enum class Kind { kLine, kArc, kTurn };
  struct Piece {
    Kind kind = Kind::kLine;
    double t0 = 0.0;
    double duration = 0.0;
    Eigen::Vector2d p0 = Eigen::Vector2d::Zero();
    double yaw0 = 0.0;
    double distance0 = 0.0;
    double rate = 0.0;       ///< m/s along lines and arcs, rad/s for turns
    double curvature = 0.0;  ///< 1/m, signed (left positive), arcs only
  };

  void addLine(const Eigen::Vector2d& from, const Eigen::Vector2d& to);
  void addArc(double curvature, double length);
  void addTurn(double to_yaw);

  std::vector<Piece> pieces_;
  double speed_;
  double turn_rate_;
  double duration_s_ = 0.0;
  PlanarState end_;
};

/// Smooth roll and pitch (rad) of the base: a few seeded sinusoids of 0.1–1 Hz.
class TiltJitter {
 public:
  TiltJitter(double amplitude_rad, std::uint64_t seed);
  Eigen::Vector2d rollPitchAt(double time_s) const;

 private:
  struct Component {
    double amplitude = 0.0, frequency_hz = 0.0, phase = 0.0;
  };
  std::vector<Component> roll_, pitch_;
};

}  // namespace mm4mm::sim
