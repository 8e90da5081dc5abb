#include "mm4mm/magnetic/pso.hpp"

#include <tbb/parallel_for.h>

#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

namespace mm4mm {

bool PsoConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (particles < 2) return fail("particles must be >= 2");
  if (iterations < 1) return fail("iterations must be >= 1");
  if (!(inertia >= 0.0 && inertia < 1.0)) return fail("inertia must be in [0, 1)");
  if (!(cognitive >= 0.0) || !(social >= 0.0)) return fail("cognitive and social must be >= 0");
  if (!(max_velocity_fraction > 0.0)) return fail("max_velocity_fraction must be > 0");
  if (stall_iterations < 1) return fail("stall_iterations must be >= 1");
  return true;
}

PsoResult psoMaximize(const std::function<double(const Eigen::VectorXd&)>& objective,
                      const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                      const PsoConfig& config, const Eigen::VectorXd* initial) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  if (lower.size() != upper.size() || (upper.array() < lower.array()).any())
    throw std::invalid_argument("pso: bounds must have one size and lower <= upper");
  const int n = config.particles;
  const Eigen::Index dims = lower.size();
  const Eigen::VectorXd span = upper - lower;
  const Eigen::VectorXd max_velocity = config.max_velocity_fraction * span;
  std::mt19937_64 rng(config.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto random_vector = [&] {
    Eigen::VectorXd v(dims);
    for (Eigen::Index d = 0; d < dims; ++d) v[d] = unit(rng);
    return v;
  };

  std::vector<Eigen::VectorXd> position(n), velocity(n), personal_best(n);
  std::vector<double> value(n), personal_value(n);
  for (int i = 0; i < n; ++i) {
    position[i] = (i == 0 && initial) ? initial->cwiseMax(lower).cwiseMin(upper)
                                      : Eigen::VectorXd(lower + random_vector().cwiseProduct(span));
    velocity[i] = (2.0 * random_vector().array() - 1.0).matrix().cwiseProduct(max_velocity);
  }
  const auto evaluate_all = [&] {
    tbb::parallel_for(0, n, [&](int i) { value[i] = objective(position[i]); });
  };

  PsoResult result;
  evaluate_all();
  result.evaluations = n;
  // Start from particle 0 so that a best exists even when every value is -infinity (for example
  // no overlap anywhere in the box).
  result.best = position[0];
  result.value = value[0];
  for (int i = 0; i < n; ++i) {
    personal_best[i] = position[i];
    personal_value[i] = value[i];
    if (value[i] > result.value) result.value = value[i], result.best = position[i];
  }
  double value_at_last_progress = result.value;
  int stalled = 0;
  for (int iteration = 1; iteration <= config.iterations; ++iteration) {
    result.iterations = iteration;
    for (int i = 0; i < n; ++i) {
      const Eigen::VectorXd r1 = random_vector(), r2 = random_vector();
      velocity[i] = config.inertia * velocity[i] +
                    config.cognitive * r1.cwiseProduct(personal_best[i] - position[i]) +
                    config.social * r2.cwiseProduct(result.best - position[i]);
      velocity[i] = velocity[i].cwiseMax(-max_velocity).cwiseMin(max_velocity);
      position[i] = (position[i] + velocity[i]).cwiseMax(lower).cwiseMin(upper);
    }
    evaluate_all();
    result.evaluations += n;
    for (int i = 0; i < n; ++i) {
      if (value[i] > personal_value[i])
        personal_value[i] = value[i], personal_best[i] = position[i];
      if (value[i] > result.value) result.value = value[i], result.best = position[i];
    }
    if (result.value - value_at_last_progress > config.tolerance) {
      value_at_last_progress = result.value;
      stalled = 0;
    } else if (++stalled >= config.stall_iterations) {
      result.converged = true;
      break;
    }
  }
  return result;
}

}  // namespace mm4mm
