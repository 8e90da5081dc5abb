#include "mm4mm/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"

namespace mm4mm::sim {
namespace {

constexpr double kMaxArcTurnRad = 100.0 * M_PI / 180.0;

double headingOf(const Eigen::Vector2d& d) { return std::atan2(d.y(), d.x()); }

}  // namespace

PlanarTrajectory::PlanarTrajectory(const Route& route, const MotionConfig& motion)
    : speed_(motion.speed_mps), turn_rate_(motion.turn_rate_dps * M_PI / 180.0) {
  std::vector<Eigen::Vector2d> points;
  for (const auto& p : route.waypoints)
    if (points.empty() || (p - points.back()).norm() > 1e-6) points.push_back(p);
  if (points.size() < 2) throw std::invalid_argument("route needs two distinct waypoints");

  end_.position = points.front();
  end_.yaw_rad = route.start_yaw_rad;
  if (motion.calibration_turns > 0.0) {
    const double angle = 2.0 * M_PI * motion.calibration_turns;
    pieces_.push_back({Kind::kTurn, duration_s_, angle / turn_rate_, end_.position, end_.yaw_rad,
                       0.0, turn_rate_, 0.0});
    duration_s_ += angle / turn_rate_;
    end_.yaw_rad = wrapAngle(end_.yaw_rad + angle);
  }
  addTurn(headingOf(points[1] - points[0]));

  Eigen::Vector2d segment_start = points[0];
  for (std::size_t i = 1; i < points.size(); ++i) {
    const Eigen::Vector2d& corner = points[i];
    if (i + 1 == points.size()) {
      addLine(segment_start, corner);
      break;
    }
    const Eigen::Vector2d in = corner - points[i - 1];
    const Eigen::Vector2d out = points[i + 1] - corner;
    const double turn = wrapAngle(headingOf(out) - headingOf(in));
    if (std::abs(turn) < 1e-9) continue;  // collinear: keep driving straight
    if (std::abs(turn) > kMaxArcTurnRad) {
      addLine(segment_start, corner);
      addTurn(headingOf(out));
      segment_start = corner;
      continue;
    }
    // Round the corner with the largest radius up to the configured one that fits both legs.
    const double half_tan = std::tan(0.5 * std::abs(turn));
    const double room = 0.45 * std::min((corner - segment_start).norm(), out.norm());
    const double radius = std::min(motion.corner_radius_m, room / half_tan);
    const double tangent = radius * half_tan;
    addLine(segment_start, corner - tangent * in.normalized());
    if (radius > 1e-6)
      addArc((turn > 0 ? 1.0 : -1.0) / radius, radius * std::abs(turn));
    else
      addTurn(headingOf(out));
    segment_start = corner + tangent * out.normalized();
  }
}

void PlanarTrajectory::addLine(const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  const double length = (to - from).norm();
  if (length < 1e-9) return;
  Piece piece{Kind::kLine,          duration_s_,     length / speed_, from,
              headingOf(to - from), end_.distance_m, speed_,          0.0};
  pieces_.push_back(piece);
  duration_s_ += piece.duration;
  end_ = {to, piece.yaw0, end_.distance_m + length};
}

void PlanarTrajectory::addArc(double curvature, double length) {
  Piece piece{Kind::kArc,   duration_s_,     length / speed_, end_.position,
              end_.yaw_rad, end_.distance_m, speed_,          curvature};
  pieces_.push_back(piece);
  duration_s_ += piece.duration;
  const double yaw1 = piece.yaw0 + curvature * length;
  end_.position += Eigen::Vector2d(std::sin(yaw1) - std::sin(piece.yaw0),
                                   std::cos(piece.yaw0) - std::cos(yaw1)) /
                   curvature;
  end_.yaw_rad = wrapAngle(yaw1);
  end_.distance_m += length;
}

void PlanarTrajectory::addTurn(double to_yaw) {
  const double delta = wrapAngle(to_yaw - end_.yaw_rad);
  if (std::abs(delta) < 1e-9) return;
  Piece piece{Kind::kTurn,  duration_s_,     std::abs(delta) / turn_rate_,         end_.position,
              end_.yaw_rad, end_.distance_m, delta > 0 ? turn_rate_ : -turn_rate_, 0.0};
  pieces_.push_back(piece);
  duration_s_ += piece.duration;
  end_.yaw_rad = wrapAngle(to_yaw);
}

PlanarState PlanarTrajectory::at(double time_s) const {
  if (pieces_.empty() || time_s >= duration_s_) return end_;
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), time_s,
                             [](double t, const Piece& p) { return t < p.t0; });
  const Piece& p = *std::prev(it == pieces_.begin() ? std::next(it) : it);
  const double dt = std::clamp(time_s - p.t0, 0.0, p.duration);
  PlanarState state;
  switch (p.kind) {
    case Kind::kLine:
      state.position = p.p0 + p.rate * dt * Eigen::Vector2d(std::cos(p.yaw0), std::sin(p.yaw0));
      state.yaw_rad = p.yaw0;
      state.distance_m = p.distance0 + p.rate * dt;
      break;
    case Kind::kArc: {
      const double s = p.rate * dt;
      const double yaw = p.yaw0 + p.curvature * s;
      state.position = p.p0 + Eigen::Vector2d(std::sin(yaw) - std::sin(p.yaw0),
                                              std::cos(p.yaw0) - std::cos(yaw)) /
                                  p.curvature;
      state.yaw_rad = wrapAngle(yaw);
      state.distance_m = p.distance0 + s;
      break;
    }
    case Kind::kTurn:
      state.position = p.p0;
      state.yaw_rad = wrapAngle(p.yaw0 + p.rate * dt);
      state.distance_m = p.distance0;
      break;
  }
  return state;
}

TiltJitter::TiltJitter(double amplitude_rad, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> frequency(0.1, 1.0), phase(0.0, 2.0 * M_PI);
  // Three components whose amplitudes add up to the configured peak.
  for (auto* axis : {&roll_, &pitch_})
    for (double share : {0.5, 0.3, 0.2})
      axis->push_back({share * amplitude_rad, frequency(rng), phase(rng)});
}

Eigen::Vector2d TiltJitter::rollPitchAt(double time_s) const {
  Eigen::Vector2d rp = Eigen::Vector2d::Zero();
  for (const auto& c : roll_)
    rp.x() += c.amplitude * std::sin(2.0 * M_PI * c.frequency_hz * time_s + c.phase);
  for (const auto& c : pitch_)
    rp.y() += c.amplitude * std::sin(2.0 * M_PI * c.frequency_hz * time_s + c.phase);
  return rp;
}

}  // namespace mm4mm::sim
