// Procedural buildings: the building type, its plan, its contents and its steel drawn from the
// world's seed. The warehouse and the corridor are the worlds the matcher was developed on; these
// are worlds it was not, so that tuning (seeds 1-20) and held-out figures (seeds 2001 and up)
// see buildings no setting was chosen on. Every range below is a building-practice figure (stud
// pitch, stall size, column grid, door width), not one fitted to a matcher result.
//
// Every plan is axis-aligned: walls and contents are boxes, lanes run along x and y, which keeps
// ray casting exact and lanes clear of the rig by construction (a lane keeps `clearance` free on
// both sides).

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "world_builders.hpp"

namespace mm4mm::sim {
namespace {

using Rng = std::mt19937_64;

double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
int uniformInt(Rng& rng, int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }
bool chance(Rng& rng, double p) { return uniform(rng, 0.0, 1.0) < p; }

// Moments per dipole (A·m², dipoles 0.5 m apart along a member) of the contents. Light-gauge
// studs and thin pipes hold a few hundred grams of steel per dipole, a radiator or cabinet a few
// kilograms, a car about a tonne over its length (vehicle detectors see 100-300 A·m² per car), a
// machine tool several tonnes.
struct ObjectMoments {
  double induced, remanent;
};
constexpr ObjectMoments kStud{0.15, 0.3};
constexpr ObjectMoments kPipe{0.5, 1.0};
constexpr ObjectMoments kRadiator{1.5, 2.0};
constexpr ObjectMoments kCabinet{2.0, 3.0};
constexpr ObjectMoments kCar{25.0, 30.0};
constexpr ObjectMoments kMachine{30.0, 40.0};

class PlanBuilder {
 public:
  PlanBuilder(World* world, SteelAnchors* anchors) : world_(world), anchors_(anchors) {}

  void box(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double z0, double z1) {
    world_->solids.push_back(boxSolid(lo, hi, z0, z1));
  }
  void steel(const Eigen::Vector3d& from, const Eigen::Vector3d& to, ObjectMoments m) {
    anchors_->push_back({SteelKind::kObject, from, to, m.induced, m.remanent});
  }
  void pillar(const Eigen::Vector2d& centre, double size, double height) {
    const Eigen::Vector2d half = Eigen::Vector2d::Constant(0.5 * size);
    box(centre - half, centre + half, 0.0, height);
    anchors_->push_back(
        {SteelKind::kPillar, {centre.x(), centre.y(), 0.0}, {centre.x(), centre.y(), height}});
  }
  // A wall along x (horizontal == true) or y from `a` to `b` along its axis, centred on the other
  // coordinate `at`; with steel studs every `stud_pitch` (0: a masonry wall without studs).
  void wall(bool along_x, double a, double b, double at, double thickness, double height,
            double stud_pitch) {
    if (b - a < 1e-6) return;
    const double h = 0.5 * thickness;
    if (along_x)
      box({a, at - h}, {b, at + h}, 0.0, height);
    else
      box({at - h, a}, {at + h, b}, 0.0, height);
    if (stud_pitch <= 0.0) return;
    for (double s = a + 0.5 * stud_pitch; s < b; s += stud_pitch) {
      const Eigen::Vector2d p = along_x ? Eigen::Vector2d(s, at) : Eigen::Vector2d(at, s);
      steel({p.x(), p.y(), 0.0}, {p.x(), p.y(), height}, kStud);
    }
  }
  // A wall with door openings: [a, b] minus each [door - width/2, door + width/2].
  void wallWithDoors(bool along_x, double a, double b, double at, std::vector<double> doors,
                     double door_width, double thickness, double height, double stud_pitch) {
    std::sort(doors.begin(), doors.end());
    double from = a;
    for (double d : doors) {
      wall(along_x, from, d - 0.5 * door_width, at, thickness, height, stud_pitch);
      from = d + 0.5 * door_width;
    }
    wall(along_x, from, b, at, thickness, height, stud_pitch);
  }

 private:
  World* world_;
  SteelAnchors* anchors_;
};

// Lane nodes of a straight lane along x at y: one per x in `xs` (sorted, deduplicated to 1 cm),
// joined in order. Returns the node ids in x order.
std::vector<int> laneAlongX(LaneGraph* lanes, std::vector<double> xs, double y) {
  std::sort(xs.begin(), xs.end());
  std::vector<int> ids;
  double last = -1e18;
  for (double x : xs) {
    if (x - last < 0.01) continue;
    ids.push_back(lanes->addNode({x, y}));
    if (ids.size() > 1) lanes->connect(ids[ids.size() - 2], ids.back());
    last = x;
  }
  return ids;
}

int nodeAt(const LaneGraph& lanes, const std::vector<int>& ids, double x) {
  for (int id : ids)
    if (std::abs(lanes.nodes[id].x() - x) < 0.01) return id;
  throw std::logic_error("procedural world: no lane node at a door");
}

// Splits [a, b] into rooms of widths drawn in [min_w, max_w] (the last absorbs the rest).
std::vector<std::pair<double, double>> partition(Rng& rng, double a, double b, double min_w,
                                                 double max_w) {
  std::vector<std::pair<double, double>> rooms;
  double x = a;
  while (b - x > 0.0) {
    double w = uniform(rng, min_w, max_w);
    if (b - (x + w) < min_w) w = b - x;
    rooms.push_back({x, x + w});
    x += w;
  }
  return rooms;
}

// Corridors along x with rooms off them: a hallway (one corridor, rooms on one or both sides) or
// an office floor (two corridors joined by cross corridors, rooms outside both and a core of
// rooms between them). Partitions are steel-stud walls (studs every 0.4-0.6 m), the outer walls
// masonry with a concrete column every 5-9 m; pipes run under the corridor ceilings; rooms hold
// radiators under their outer walls and steel cabinets and desks.
World buildCorridorsAndRooms(bool office, double clearance, Rng& rng, SteelAnchors* anchors) {
  World world;
  world.name = office ? "office" : "hallway";
  PlanBuilder plan(&world, anchors);
  const double length = office ? uniform(rng, 35.0, 70.0) : uniform(rng, 40.0, 110.0);
  const double corridor_w =
      uniform(rng, std::max(1.8, 2.0 * clearance + 0.4), std::max(3.2, 2.0 * clearance + 1.2));
  const double height = uniform(rng, 2.7, 3.5);
  const double door_w = std::max(1.0, 2.0 * clearance + 0.3);
  const double stud_pitch = uniform(rng, 0.4, 0.6);
  const double t = 0.12;  // partition thickness
  const double room_min = std::max(3.0, door_w + 0.8), room_max = room_min + 4.0;

  // Bands across y, bottom to top: rooms | corridor | (core | corridor) | rooms.
  struct Band {
    double y0, y1;
    bool corridor;
  };
  std::vector<Band> bands;
  double y = 0.0;
  const bool rooms_low = office || chance(rng, 0.8);
  const bool rooms_high = office || !rooms_low || chance(rng, 0.8);
  const auto add = [&](double depth, bool corridor) {
    bands.push_back({y, y + depth, corridor});
    y += depth;
  };
  if (rooms_low) add(uniform(rng, 3.5, 7.0), false);
  add(corridor_w, true);
  if (office) {
    add(uniform(rng, 5.0, 12.0), false);
    add(corridor_w, true);
  }
  if (rooms_high) add(uniform(rng, 3.5, 7.0), false);
  world.floor_xy = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(length, y));
  world.ceiling_height_m = height;

  // Cross corridors of an office cut through the core: near both ends and, when long, midway.
  std::vector<double> crosses;
  if (office) {
    const double margin = 0.5 * corridor_w + uniform(rng, 0.5, 3.0);
    crosses = {margin, length - margin};
    if (length > 45.0) crosses.push_back(uniform(rng, 0.35, 0.65) * length);
  }

  // Corridor lanes: nodes every 4 m, at each door and each cross corridor.
  std::vector<std::vector<int>> corridor_ids;
  std::vector<double> corridor_y;
  std::vector<std::vector<double>> corridor_doors;  // per corridor band, door x positions
  std::vector<double> base_xs;
  for (double x = clearance + 0.3; x <= length - clearance - 0.3; x += 4.0) base_xs.push_back(x);
  for (const Band& band : bands)
    if (band.corridor) corridor_y.push_back(0.5 * (band.y0 + band.y1));
  corridor_doors.resize(corridor_y.size());

  // Rooms: a door onto one adjacent corridor; walls on all four sides.
  struct Room {
    double x0, x1, y0, y1;
    int corridor = -1;  // which corridor the door opens on (-1: none)
    double door_x = 0.0;
  };
  std::vector<Room> rooms;
  for (std::size_t bi = 0; bi < bands.size(); ++bi) {
    const Band& band = bands[bi];
    if (band.corridor) continue;
    std::vector<int> adjacent;  // corridor indices below and above
    int ci = 0;
    for (std::size_t bj = 0; bj < bands.size(); ++bj) {
      if (!bands[bj].corridor) continue;
      if (bj + 1 == bi || bj == bi + 1) adjacent.push_back(ci);
      ++ci;
    }
    // The core is cut by the cross corridors: rooms fill the stretches between them.
    std::vector<std::pair<double, double>> stretches{{0.0, length}};
    if (adjacent.size() == 2) {
      stretches.clear();
      std::vector<double> cuts = crosses;
      std::sort(cuts.begin(), cuts.end());
      double from = 0.0;
      for (double c : cuts) {
        stretches.push_back({from, c - 0.5 * corridor_w});
        from = c + 0.5 * corridor_w;
      }
      stretches.push_back({from, length});
    }
    for (const auto& [a, b] : stretches) {
      if (b - a < 1.0) continue;
      for (const auto& [x0, x1] : partition(rng, a, b, room_min, room_max)) {
        Room room{x0, x1, band.y0, band.y1};
        const bool enterable =
            x1 - x0 >= door_w + 0.6 && band.y1 - band.y0 >= 2.0 * clearance + 0.6;
        if (!adjacent.empty() && enterable && chance(rng, 0.85)) {
          room.corridor = adjacent[uniformInt(rng, 0, static_cast<int>(adjacent.size()) - 1)];
          room.door_x = uniform(rng, x0 + 0.5 * door_w + 0.3, x1 - 0.5 * door_w - 0.3);
          corridor_doors[room.corridor].push_back(room.door_x);
        }
        rooms.push_back(room);
      }
    }
  }

  for (std::size_t c = 0; c < corridor_y.size(); ++c) {
    std::vector<double> xs = base_xs;
    xs.insert(xs.end(), corridor_doors[c].begin(), corridor_doors[c].end());
    xs.insert(xs.end(), crosses.begin(), crosses.end());
    corridor_ids.push_back(laneAlongX(&world.lanes, xs, corridor_y[c]));
  }
  if (corridor_ids.size() == 2)
    for (double x : crosses)
      world.lanes.connect(nodeAt(world.lanes, corridor_ids[0], x),
                          nodeAt(world.lanes, corridor_ids[1], x));

  for (const Room& room : rooms) {
    // Walls on the room's four sides; the one on its door's corridor has the opening.
    const double door_side_y = room.corridor < 0                     ? -1.0
                               : corridor_y[room.corridor] < room.y0 ? room.y0
                                                                     : room.y1;
    for (double wy : {room.y0, room.y1}) {
      const bool outer = wy <= 1e-6 || wy >= y - 1e-6;
      if (outer) continue;  // the enclosing wall
      std::vector<double> doors;
      if (std::abs(wy - door_side_y) < 1e-6) doors.push_back(room.door_x);
      plan.wallWithDoors(true, room.x0, room.x1, wy, doors, door_w, t, height, stud_pitch);
    }
    for (double wx : {room.x0, room.x1})
      if (wx > 1e-6 && wx < length - 1e-6)
        plan.wall(false, room.y0, room.y1, wx, t, height, stud_pitch);
    if (room.corridor >= 0) {
      const int door_node = nodeAt(world.lanes, corridor_ids[room.corridor], room.door_x);
      const int inside = world.lanes.addNode({room.door_x, 0.5 * (room.y0 + room.y1)});
      world.lanes.connect(door_node, inside);
    }
    // Contents: a radiator under an outer wall, steel cabinets along the side walls, desks.
    const bool outer_low = room.y0 <= 1e-6, outer_high = room.y1 >= y - 1e-6;
    if ((outer_low || outer_high) && chance(rng, 0.7)) {
      const double ry = outer_low ? room.y0 + 0.15 : room.y1 - 0.15;
      const double rx0 = uniform(rng, room.x0 + 0.3, 0.5 * (room.x0 + room.x1));
      plan.steel({rx0, ry, 0.3}, {rx0 + uniform(rng, 0.8, 1.6), ry, 0.3}, kRadiator);
    }
    const int cabinets = uniformInt(rng, 0, office ? 3 : 2);
    for (int k = 0; k < cabinets; ++k) {
      const bool left = chance(rng, 0.5);
      const double cx = left ? room.x0 + 0.35 : room.x1 - 0.35;
      const double cy = uniform(rng, room.y0 + 0.6, room.y1 - 0.6);
      if (room.corridor >= 0 && std::abs(cx - room.door_x) < 0.5 * door_w + 0.5) continue;
      const double top = uniform(rng, 1.0, 2.0);
      plan.box({cx - 0.25, cy - 0.45}, {cx + 0.25, cy + 0.45}, 0.0, top);
      plan.steel({cx, cy - 0.3, 0.5 * top}, {cx, cy + 0.3, 0.5 * top}, kCabinet);
    }
  }
  // Masonry outer walls with concrete columns in them; pipes under the corridor ceilings.
  const double column_pitch = uniform(rng, 5.0, 9.0);
  for (double x = uniform(rng, 0.5, column_pitch); x < length; x += column_pitch)
    for (double cy : {-0.15, y + 0.15}) plan.pillar({x, cy}, 0.3, height);
  for (double cy : corridor_y) {
    const int pipes = uniformInt(rng, 0, 2);
    for (int k = 0; k < pipes; ++k) {
      const double py = cy + uniform(rng, -0.4, 0.4) * corridor_w;
      plan.steel({0.0, py, height - 0.3}, {length, py, height - 0.3}, kPipe);
    }
  }
  addEnclosingWalls(&world, 0.3);
  return world;
}

// A parking garage: aisle modules (a row of stalls, a 6-7 m drive aisle, a row of stalls) across
// y, drive lanes at both x ends, columns on the lines between modules and along the walls every
// three stalls; cars parked at random with their own steel.
World buildGarage(double clearance, Rng& rng, SteelAnchors* anchors) {
  World world;
  world.name = "garage";
  PlanBuilder plan(&world, anchors);
  const double stall_w = uniform(rng, 2.4, 2.8), stall_d = uniform(rng, 4.8, 5.5);
  const double aisle = std::max(uniform(rng, 6.0, 7.0), 2.0 * clearance + 1.0);
  const double end_lane = std::max(uniform(rng, 6.0, 7.0), 2.0 * clearance + 1.0);
  const int stalls = 3 * uniformInt(rng, 4, 10);  // along x, a column every three
  const int modules = uniformInt(rng, 2, 4);
  const double height = uniform(rng, 2.4, 3.0);
  const double occupancy = uniform(rng, 0.2, 0.9);
  const double module_d = 2.0 * stall_d + aisle;
  const double length = stalls * stall_w + 2.0 * end_lane;
  const double depth = modules * module_d;
  world.floor_xy = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(length, depth));
  world.ceiling_height_m = height;

  const double x_stalls = end_lane;
  const double column = uniform(rng, 0.4, 0.6);
  std::vector<double> column_xs;
  for (int k = 0; k <= stalls; k += 3) column_xs.push_back(x_stalls + k * stall_w);
  for (int m = 0; m <= modules; ++m) {
    const double cy = m == 0 ? 0.5 * column : m == modules ? depth - 0.5 * column : m * module_d;
    for (double cx : column_xs) plan.pillar({cx, cy}, column, height);
  }
  // Cars: body and cabin boxes, steel as a chain along the car at wheel-axle height.
  const auto park = [&](double x0, double y0, double y1) {
    const double car_l = uniform(rng, 4.0, 4.9), car_w = uniform(rng, 1.7, 1.9);
    const double cx = x0 + 0.5 * stall_w, cy = 0.5 * (y0 + y1) + uniform(rng, -0.2, 0.2);
    const Eigen::Vector2d half(0.5 * car_w, 0.5 * car_l);
    plan.box(Eigen::Vector2d(cx, cy) - half, Eigen::Vector2d(cx, cy) + half, 0.2, 1.0);
    plan.box(Eigen::Vector2d(cx, cy) - Eigen::Vector2d(0.45 * car_w, 0.25 * car_l),
             Eigen::Vector2d(cx, cy) + Eigen::Vector2d(0.45 * car_w, 0.2 * car_l), 1.0,
             uniform(rng, 1.4, 1.6));
    plan.steel({cx, cy - 0.4 * car_l, 0.45}, {cx, cy + 0.4 * car_l, 0.45}, kCar);
  };
  std::vector<std::vector<int>> aisle_ids;
  std::vector<double> lane_xs{0.5 * end_lane, length - 0.5 * end_lane};
  for (double cx : column_xs) lane_xs.push_back(cx);
  for (int m = 0; m < modules; ++m) {
    const double y0 = m * module_d;
    for (int k = 0; k < stalls; ++k) {
      const double x0 = x_stalls + k * stall_w;
      if (chance(rng, occupancy)) park(x0, y0 + 0.3, y0 + stall_d);
      if (chance(rng, occupancy)) park(x0, y0 + stall_d + aisle, y0 + module_d - 0.3);
    }
    aisle_ids.push_back(laneAlongX(&world.lanes, lane_xs, y0 + stall_d + 0.5 * aisle));
  }
  for (std::size_t m = 0; m + 1 < aisle_ids.size(); ++m)
    for (double x : {lane_xs[0], lane_xs[1]})
      world.lanes.connect(nodeAt(world.lanes, aisle_ids[m], x),
                          nodeAt(world.lanes, aisle_ids[m + 1], x));
  // Sprinkler and drain pipes under the slab above.
  for (int k = uniformInt(rng, 1, 4); k > 0; --k) {
    const double py = uniform(rng, 0.0, depth);
    plan.steel({0.0, py, height - 0.2}, {length, py, height - 0.2}, kPipe);
  }
  addEnclosingWalls(&world, 0.3);
  return world;
}

// Rack aisles: the warehouse builder with every dimension drawn (rows, blocks, bays, aisle and
// rack sizes, shelf levels, pillars), the hall sized to hold them with perimeter lanes.
World buildRacks(double clearance, Rng& rng, SteelAnchors* anchors) {
  WarehouseConfig c;
  c.shelf_rows = uniformInt(rng, 5, 9);  // enough aisles to keep a disjoint session apart
  c.shelf_blocks = uniformInt(rng, 1, 3);
  c.bays_per_block = uniformInt(rng, 6, 14);
  c.bay_width_m = uniform(rng, 2.4, 3.0);
  c.rack_depth_m = uniform(rng, 0.9, 1.2);
  c.rack_gap_m = uniform(rng, 0.1, 0.3);
  c.aisle_width_m =
      uniform(rng, std::max(2.8, 2.0 * clearance + 0.6), std::max(4.2, 2.0 * clearance + 1.4));
  c.shelf_levels_m.clear();
  const double level = uniform(rng, 1.2, 1.8);
  const int levels = uniformInt(rng, 3, 5);
  for (int k = 0; k < levels; ++k) c.shelf_levels_m.push_back(0.15 + k * level);
  c.shelf_top_m = c.shelf_levels_m.back() + uniform(rng, 1.0, 1.6);
  c.height_m = c.shelf_top_m + uniform(rng, 1.5, 4.0);
  c.goods_fill = uniform(rng, 0.5, 0.9);
  c.pillar_size_m = uniform(rng, 0.4, 0.7);
  c.pillar_offset_from_rows_m = uniform(rng, 0.1, 0.4);
  // Row-end pillars stand in the cross aisles: the lane between them keeps the rig clear.
  c.cross_aisle_width_m = 2.0 * (c.pillar_offset_from_rows_m + c.pillar_size_m) +
                          uniform(rng, 2.0 * clearance + 0.6, 2.0 * clearance + 2.5);
  const double band = uniform(rng, std::max(3.0, 2.0 * clearance + 0.6), 6.0);
  const double reach = 2.0 * (c.pillar_offset_from_rows_m + c.pillar_size_m + band);
  c.size_y_m = c.shelf_rows * (2.0 * c.rack_depth_m + c.rack_gap_m) +
               (c.shelf_rows - 1) * c.aisle_width_m + reach;
  c.size_x_m = c.shelf_blocks * c.bays_per_block * c.bay_width_m +
               (c.shelf_blocks - 1) * c.cross_aisle_width_m + reach;
  World world = buildWarehouse(c, anchors);
  world.name = "racks";
  return world;
}

// An open hall: a lane grid 5-9 m apart, columns at some grid cells' centres, machines (steel
// boxes of several tonnes) in others, ducts and cable trays at random.
World buildHall(double clearance, Rng& rng, SteelAnchors* anchors) {
  World world;
  world.name = "hall";
  PlanBuilder plan(&world, anchors);
  const double pitch = std::max(uniform(rng, 5.0, 9.0), 2.0 * clearance + 2.0);
  const int nx = uniformInt(rng, 6, 11), ny = uniformInt(rng, 4, 8);
  const double height = uniform(rng, 5.0, 12.0);
  const double margin = std::max(2.0, clearance + 0.8);
  const double length = (nx - 1) * pitch + 2.0 * margin, depth = (ny - 1) * pitch + 2.0 * margin;
  world.floor_xy = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(length, depth));
  world.ceiling_height_m = height;
  std::vector<double> xs, ys;
  for (int i = 0; i < nx; ++i) xs.push_back(margin + i * pitch);
  for (int j = 0; j < ny; ++j) ys.push_back(margin + j * pitch);
  world.lanes = gridLanes(xs, ys);
  // Cell interiors keep `clearance` + 0.3 m from the lanes around them.
  const double free_half = 0.5 * pitch - clearance - 0.3;
  const double machine_share = uniform(rng, 0.2, 0.6);
  for (int i = 0; i + 1 < nx; ++i)
    for (int j = 0; j + 1 < ny; ++j) {
      const Eigen::Vector2d centre(xs[i] + 0.5 * pitch, ys[j] + 0.5 * pitch);
      if ((i + j) % 2 == 0 && chance(rng, 0.5)) {
        plan.pillar(centre, uniform(rng, 0.4, 0.8), height);
      } else if (free_half > 0.4 && chance(rng, machine_share)) {
        const Eigen::Vector2d half(uniform(rng, 0.4, free_half), uniform(rng, 0.4, free_half));
        const double top = uniform(rng, 1.0, 3.0);
        plan.box(centre - half, centre + half, 0.0, top);
        const bool along_x = half.x() >= half.y();
        const Eigen::Vector2d a =
            centre - (along_x ? Eigen::Vector2d(half.x(), 0) : Eigen::Vector2d(0, half.y()));
        const Eigen::Vector2d b = 2.0 * centre - a;
        plan.steel({a.x(), a.y(), 0.4}, {b.x(), b.y(), 0.4}, kMachine);
      }
    }
  for (int k = uniformInt(rng, 1, 5); k > 0; --k) {
    const bool along_x = chance(rng, 0.5);
    const double at = uniform(rng, 0.0, along_x ? depth : length);
    const double z = chance(rng, 0.3) ? 0.05 : height - 0.5;  // a floor trench or a ceiling duct
    if (along_x)
      plan.steel({0.0, at, z}, {length, at, z}, kPipe);
    else
      plan.steel({at, 0.0, z}, {at, depth, z}, kPipe);
  }
  addEnclosingWalls(&world, 0.3);
  return world;
}

// Floors differ: mesh or no mesh, its bar pitch and cover, how strongly its bars are magnetised,
// how much loose steel the slab holds.
void drawFloorSteel(Rng& rng, SimulationConfig* config) {
  FloorMeshConfig& mesh = config->floor_mesh;
  mesh.enabled = chance(rng, 0.85);
  mesh.bar_spacing_m = uniform(rng, 0.15, 0.3);
  mesh.bar_diameter_m = uniform(rng, 0.006, 0.012);
  mesh.depth_m = uniform(rng, 0.03, 0.08);
  mesh.remanent_magnetisation_A_per_m = uniform(rng, 5000.0, 40000.0);
  FloorSteelConfig& steel = config->floor_steel;
  steel.density_per_m2 = uniform(rng, 0.05, 0.6);
  // Log-uniform: from a quiet slab (a few conduit boxes) to one full of embedded plates and
  // anchors; the Aalto lab's field (B_h spread 7-14 µT, correlation length 0.4-0.7 m) lies
  // inside what this range gives (docs/benchmarks.md, procedural field statistics).
  steel.moment_Am2 = std::exp(uniform(rng, std::log(1.0), std::log(25.0)));
  steel.min_depth_m = 0.03;
  steel.max_depth_m = uniform(rng, 0.1, 0.3);
}

// The plan axis along which the lanes have more distinct positions (the longer one on a tie):
// the one a disjoint session can be kept apart along.
int axisWithMoreLevels(const World& world) {
  std::set<long> levels[2];
  for (const Eigen::Vector2d& p : world.lanes.nodes)
    for (int axis : {0, 1}) levels[axis].insert(std::lround(p[axis] * 100.0));
  if (levels[0].size() != levels[1].size()) return levels[0].size() > levels[1].size() ? 0 : 1;
  const Eigen::Vector2d size = world.floor_xy.sizes();
  return size.x() >= size.y() ? 0 : 1;
}

World buildBuilding(const std::string& building, double clearance_m, Rng& rng,
                    SteelAnchors* anchors) {
  if (building == "hallway") return buildCorridorsAndRooms(false, clearance_m, rng, anchors);
  if (building == "office") return buildCorridorsAndRooms(true, clearance_m, rng, anchors);
  if (building == "garage") return buildGarage(clearance_m, rng, anchors);
  if (building == "racks") return buildRacks(clearance_m, rng, anchors);
  if (building == "hall") return buildHall(clearance_m, rng, anchors);
  throw std::invalid_argument(
      "procedural.building must be any, hallway, office, garage, racks "
      "or hall, got '" +
      building + "'");
}

}  // namespace

const std::vector<std::string>& proceduralBuildings() {
  static const std::vector<std::string> kBuildings{"hallway", "office", "garage", "racks", "hall"};
  return kBuildings;
}

World buildProcedural(SimulationConfig* config, double clearance_m, std::uint64_t seed,
                      SteelAnchors* anchors) {
  Rng rng(seed);
  std::string building = config->procedural.building;
  const auto& buildings = proceduralBuildings();
  if (building == "any")
    building = buildings[uniformInt(rng, 0, static_cast<int>(buildings.size()) - 1)];
  if (config->procedural.draw_floor_steel) drawFloorSteel(rng, config);
  World world = buildBuilding(building, clearance_m, rng, anchors);
  world.split_axis = axisWithMoreLevels(world);
  return world;
}

}  // namespace mm4mm::sim
