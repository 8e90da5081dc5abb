#include "mm4mm/sim/world_change.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mm4mm::sim {
namespace {

bool holdsDipole(const Eigen::AlignedBox2d& box, const MagneticDipole& dipole) {
  // The floor's own steel (below z = 0) is part of the building, not of what stands on it.
  return dipole.position_m.z() >= 0.0 && box.contains(dipole.position_m.head<2>());
}

bool holdsSolid(const Eigen::AlignedBox2d& box, const Solid& solid) {
  return box.contains(solid.planBounds());
}

std::string describe(const char* list, std::size_t index) {
  return std::string("change.") + list + "[" + std::to_string(index) + "]";
}

}  // namespace

Eigen::AlignedBox2d changeBox(const std::vector<double>& box) {
  if (box.size() != 4) throw std::invalid_argument("a change box needs 4 numbers");
  return Eigen::AlignedBox2d(Eigen::Vector2d(box[0], box[1]), Eigen::Vector2d(box[2], box[3]));
}

BoxContents boxContents(const World& world, const Eigen::AlignedBox2d& box) {
  BoxContents contents;
  for (const MagneticDipole& d : world.dipoles) contents.dipoles += holdsDipole(box, d) ? 1 : 0;
  for (const Solid& s : world.solids) contents.solids += holdsSolid(box, s) ? 1 : 0;
  return contents;
}

World changedWorld(const World& world, const ChangeConfig& change, bool after) {
  // Both lists are checked whichever state is asked for: a box that holds nothing is a mistake.
  const auto boxes = [&](const std::vector<std::vector<double>>& list, const char* name) {
    std::vector<Eigen::AlignedBox2d> checked;
    for (std::size_t i = 0; i < list.size(); ++i) {
      checked.push_back(changeBox(list[i]));
      const BoxContents contents = boxContents(world, checked.back());
      if (contents.dipoles == 0 && contents.solids == 0)
        throw std::invalid_argument(describe(name, i) +
                                    " holds no steel and no solid of the world: the change would "
                                    "change nothing there");
    }
    return checked;
  };
  const std::vector<Eigen::AlignedBox2d> removed = boxes(change.removed_m, "removed_m");
  const std::vector<Eigen::AlignedBox2d> added = boxes(change.added_m, "added_m");
  // Before the change what is brought in is not there yet; after it, what is taken away is gone.
  const std::vector<Eigen::AlignedBox2d>& gone = after ? removed : added;
  World changed = world;
  const auto inAny = [&](auto holds) {
    return [&, holds](const auto& item) {
      return std::any_of(gone.begin(), gone.end(),
                         [&](const Eigen::AlignedBox2d& box) { return holds(box, item); });
    };
  };
  changed.dipoles.erase(
      std::remove_if(changed.dipoles.begin(), changed.dipoles.end(), inAny(holdsDipole)),
      changed.dipoles.end());
  changed.solids.erase(
      std::remove_if(changed.solids.begin(), changed.solids.end(), inAny(holdsSolid)),
      changed.solids.end());
  return changed;
}

ChangeTruth changeTruth(const MagneticFieldModel& before, const MagneticFieldModel& after,
                        const ChangeConfig& change, double height_m) {
  ChangeTruth truth;
  truth.cell_m = change.truth_cell_m;
  truth.height_m = height_m;
  Eigen::AlignedBox2d area;
  for (const auto* boxes : {&change.removed_m, &change.added_m})
    for (const auto& box : *boxes) area.extend(changeBox(box));
  if (area.isEmpty()) return truth;
  const Eigen::Vector2d margin = Eigen::Vector2d::Constant(change.truth_margin_m);
  truth.origin_m = area.min() - margin;
  const Eigen::Vector2d size = area.sizes() + 2.0 * margin;
  truth.width = static_cast<int>(std::ceil(size.x() / truth.cell_m));
  truth.height = static_cast<int>(std::ceil(size.y() / truth.cell_m));
  const std::size_t cells = static_cast<std::size_t>(truth.width) * truth.height;
  for (auto* values : {&truth.delta_h_uT, &truth.delta_v_uT, &truth.delta_x_uT, &truth.delta_y_uT})
    values->resize(cells);
  tbb::parallel_for(0, truth.height, [&](int iy) {
    for (int ix = 0; ix < truth.width; ++ix) {
      const Eigen::Vector2d xy =
          truth.origin_m + truth.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const Eigen::Vector3d p(xy.x(), xy.y(), height_m);
      const Eigen::Vector3d b0 = before.fieldAt(p), b1 = after.fieldAt(p);
      const std::size_t i = static_cast<std::size_t>(iy) * truth.width + ix;
      truth.delta_h_uT[i] = static_cast<float>(b1.head<2>().norm() - b0.head<2>().norm());
      truth.delta_v_uT[i] = static_cast<float>(b1.z() - b0.z());
      truth.delta_x_uT[i] = static_cast<float>(b1.x() - b0.x());
      truth.delta_y_uT[i] = static_cast<float>(b1.y() - b0.y());
    }
  });
  truth.changed.resize(cells);
  for (std::size_t i = 0; i < cells; ++i) {
    const double magnitude = std::hypot(truth.delta_h_uT[i], truth.delta_v_uT[i]);
    truth.changed[i] = magnitude >= change.truth_threshold_uT;
    truth.largest_uT = std::max(truth.largest_uT, magnitude);
    if (truth.changed[i]) truth.changed_area_m2 += truth.cell_m * truth.cell_m;
  }
  return truth;
}

}  // namespace mm4mm::sim
