#include "mm4mm/io/magnetic_map_io.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "pcd_blob.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using io_detail::encodePcd;
using io_detail::floatBlob;
using io_detail::formatNumber;
using io_detail::putFloats;

constexpr const char* kGridTag = "mm4mm_magnetic_grid";
// Far beyond any building (a 1 km x 1 km hall at 5 cm has 4e8 cells); a corrupt comment must not
// make the reader allocate terabytes.
constexpr double kMaxCells = 5e8;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Writing

void checkSizes(const MagneticMap& map) {
  const auto cells = static_cast<std::size_t>(std::max(0, map.width)) * std::max(0, map.height);
  for (const auto* values :
       {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT, &map.session_y_uT})
    if (values->size() != cells)
      throw std::invalid_argument(
          "writeMagneticMapPcd: a field holds " + std::to_string(values->size()) + " values for " +
          std::to_string(map.width) + " x " + std::to_string(map.height) + " cells");
  if (map.width < 0 || map.height < 0 || !(map.cell_size_m > 0.0) || !map.origin_m.allFinite() ||
      !std::isfinite(map.height_m))
    throw std::invalid_argument("writeMagneticMapPcd: invalid grid geometry");
}

// A MagneticMap or a ChangeMap: both carry the same grid.
template <typename Grid>
std::string gridComment(const Grid& map) {
  return std::string(kGridTag) + " origin_x_m=" + formatNumber(map.origin_m.x()) +
         " origin_y_m=" + formatNumber(map.origin_m.y()) +
         " cell_size_m=" + formatNumber(map.cell_size_m) + " width=" + std::to_string(map.width) +
         " height=" + std::to_string(map.height) + " height_m=" + formatNumber(map.height_m);
}

// ---------------------------------------------------------------------------------------------
// Reading

struct GridGeometry {
  Eigen::Vector2d origin_m;
  double cell_size_m;
  int width, height;
  double height_m;
};

GridGeometry parseGridComment(const std::string& text, int line, const fs::path& file) {
  std::map<std::string, double> values;
  std::istringstream words(text);
  for (std::string word; words >> word;) {
    const std::size_t equals = word.find('=');
    if (equals == std::string::npos)
      throw InputError(file.string(), line,
                       std::string(kGridTag) + ": expected key=value, got '" + word + "'");
    const std::string key = word.substr(0, equals);
    values[key] = io_detail::parseFiniteNumber(std::string_view(word).substr(equals + 1), key,
                                               file.string(), line);
  }
  const auto get = [&](const char* key) {
    const auto found = values.find(key);
    if (found == values.end())
      throw InputError(file.string(), line, std::string(kGridTag) + ": missing " + key);
    return found->second;
  };
  const auto count = [&](const char* key) {
    const double value = get(key);
    if (value < 0 || value > 1e9 || value != std::floor(value))
      throw InputError(file.string(), line,
                       std::string(kGridTag) + ": " + key + " must be a whole number of cells");
    return static_cast<int>(value);
  };
  GridGeometry grid{{get("origin_x_m"), get("origin_y_m")},
                    get("cell_size_m"),
                    count("width"),
                    count("height"),
                    get("height_m")};
  if (!(grid.cell_size_m > 0.0))
    throw InputError(file.string(), line, std::string(kGridTag) + ": cell_size_m must be > 0");
  if (static_cast<double>(grid.width) * grid.height > kMaxCells)
    throw InputError(file.string(), line,
                     std::string(kGridTag) + ": " + std::to_string(grid.width) + " x " +
                         std::to_string(grid.height) + " cells is implausibly large");
  return grid;
}

// One named field of every point, as double (float32 or float64 in the file).
std::optional<std::vector<double>> column(const pcl::PCLPointCloud2& blob, const std::string& name,
                                          const fs::path& file) {
  const auto field = std::find_if(blob.fields.begin(), blob.fields.end(),
                                  [&](const pcl::PCLPointField& f) { return f.name == name; });
  if (field == blob.fields.end()) return std::nullopt;
  const bool is_float = field->datatype == pcl::PCLPointField::FLOAT32;
  if ((!is_float && field->datatype != pcl::PCLPointField::FLOAT64) || field->count != 1)
    throw InputError(file.string(), 0, "field " + name + " must be one float32 or float64");
  if (field->offset + (is_float ? 4u : 8u) > blob.point_step)
    throw InputError(file.string(), 0, "field " + name + " lies beyond its point size");
  std::vector<double> values;
  values.reserve(std::size_t{blob.width} * blob.height);
  for (std::uint32_t row = 0; row < blob.height; ++row)
    for (std::uint32_t col = 0; col < blob.width; ++col) {
      const std::uint8_t* bytes = &blob.data[std::size_t{row} * blob.row_step +
                                             std::size_t{col} * blob.point_step + field->offset];
      if (is_float) {
        float value;
        std::memcpy(&value, bytes, sizeof(value));
        values.push_back(value);
      } else {
        double value;
        std::memcpy(&value, bytes, sizeof(value));
        values.push_back(value);
      }
    }
  return values;
}

// Cell size and origin of the grid whose centres are `centres` (one axis): the smallest gap
// between distinct centres, refined over the whole span so float rounding does not accumulate.
std::optional<std::pair<double, double>> axisGrid(std::vector<double> centres) {
  std::sort(centres.begin(), centres.end());
  centres.erase(std::unique(centres.begin(), centres.end()), centres.end());
  if (centres.size() < 2) return std::nullopt;
  double gap = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < centres.size(); ++i) gap = std::min(gap, centres[i] - centres[i - 1]);
  const double span = centres.back() - centres.front();
  const double cell = span / std::round(span / gap);
  return std::make_pair(cell, centres.front());
}

GridGeometry inferGrid(const std::vector<double>& x, const std::vector<double>& y,
                       const std::optional<std::vector<double>>& z, const fs::path& file) {
  const auto along_x = axisGrid(x), along_y = axisGrid(y);
  if (!along_x && !along_y)
    throw InputError(file.string(), 0,
                     "has no '# " + std::string(kGridTag) +
                         "' comment and too few cells to infer the cell size from");
  const double cell = along_x ? along_x->first : along_y->first;
  GridGeometry grid;
  grid.cell_size_m = cell;
  const double min_x = *std::min_element(x.begin(), x.end());
  const double min_y = *std::min_element(y.begin(), y.end());
  grid.origin_m = Eigen::Vector2d(min_x, min_y).array() - 0.5 * cell;
  // Checked before rounding to int: a far coordinate overflows the cast (the fuzzer's
  // -03333333333333333 made the width negative and the grid's allocation throw).
  const double cells_x = std::round((*std::max_element(x.begin(), x.end()) - min_x) / cell) + 1.0;
  const double cells_y = std::round((*std::max_element(y.begin(), y.end()) - min_y) / cell) + 1.0;
  if (!(cells_x * cells_y <= kMaxCells))
    throw InputError(file.string(), 0,
                     "has no '# " + std::string(kGridTag) +
                         "' comment and its points imply an implausibly large grid");
  grid.width = static_cast<int>(cells_x);
  grid.height = static_cast<int>(cells_y);
  double z_sum = 0.0;
  if (z)
    for (double value : *z) z_sum += value;
  grid.height_m = z ? z_sum / static_cast<double>(z->size()) : 0.0;
  return grid;
}

// A grid far larger than its fingerprints is a damaged or hostile file, not a map, and would
// take gigabytes (20 bytes a cell): up to 10 M cells are allowed whatever the points, beyond that
// at most 1000 cells per fingerprint (sessions 1 km apart still cover more than 0.1 %). Found by
// fuzz/fuzz_magnetic_map_pcd.cpp: two points 5000 km apart asked for 10 GB.
void checkGridFits(const GridGeometry& grid, std::size_t points, const fs::path& file) {
  const double cells = static_cast<double>(grid.width) * grid.height;
  if (cells > std::max(1e7, 1000.0 * static_cast<double>(points)))
    throw InputError(file.string(), 0,
                     "a grid of " + std::to_string(grid.width) + " x " +
                         std::to_string(grid.height) + " cells for " + std::to_string(points) +
                         " fingerprints is implausibly large");
}

MagneticMap emptyMap(const GridGeometry& grid) {
  MagneticMap map;
  map.origin_m = grid.origin_m;
  map.cell_size_m = grid.cell_size_m;
  map.width = grid.width;
  map.height = grid.height;
  map.height_m = grid.height_m;
  const std::size_t cells = static_cast<std::size_t>(grid.width) * grid.height;
  for (auto* values :
       {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT, &map.session_y_uT})
    values->assign(cells, kNaN);
  return map;
}

// The cell whose centre is (x, y); the centre must be within 1 % of a cell of the point.
std::size_t cellOf(const MagneticMap& map, double x, double y, std::size_t point,
                   const fs::path& file) {
  const double fx = (x - map.origin_m.x()) / map.cell_size_m - 0.5;
  const double fy = (y - map.origin_m.y()) / map.cell_size_m - 0.5;
  const double ix = std::round(fx), iy = std::round(fy);
  const auto where = [&] {
    return "point " + std::to_string(point) + " at (" + formatNumber(x) + ", " + formatNumber(y) +
           ")";
  };
  // float32 centres of a map hundreds of metres from its origin are off by up to ~1e-5 m.
  const double tolerance = 0.01 + 1e-4 / map.cell_size_m;
  if (std::abs(fx - ix) > tolerance || std::abs(fy - iy) > tolerance)
    throw InputError(file.string(), 0, where() + " is not at a cell centre of the grid");
  if (ix < 0 || iy < 0 || ix >= map.width || iy >= map.height)
    throw InputError(file.string(), 0, where() + " lies outside the grid");
  return map.index(static_cast<int>(ix), static_cast<int>(iy));
}

}  // namespace

void writeMagneticMapPcd(const fs::path& file, const MagneticMap& map) {
  checkSizes(map);
  std::vector<std::size_t> covered;
  for (std::size_t i = 0; i < map.total_uT.size(); ++i)
    if (!std::isnan(map.total_uT[i])) covered.push_back(i);
  pcl::PCLPointCloud2 blob =
      floatBlob({"x", "y", "z", "bh", "bv", "bf", "bx", "by"}, covered.size());
  for (std::size_t k = 0; k < covered.size(); ++k) {
    const std::size_t i = covered[k];
    if (!std::isfinite(map.horizontal_uT[i]) || !std::isfinite(map.vertical_uT[i]) ||
        !std::isfinite(map.total_uT[i]))
      throw std::invalid_argument("writeMagneticMapPcd: covered cell " + std::to_string(i) +
                                  " has a non-finite fingerprint");
    const Eigen::Vector2d centre =
        map.cellCentre(static_cast<int>(i % map.width), static_cast<int>(i / map.width));
    putFloats(&blob, k,
              {static_cast<float>(centre.x()), static_cast<float>(centre.y()),
               static_cast<float>(map.height_m), map.horizontal_uT[i], map.vertical_uT[i],
               map.total_uT[i], map.session_x_uT[i], map.session_y_uT[i]});
  }
  io_detail::writeFileAtomically(file, encodePcd(blob, gridComment(map), file));
}

MagneticMap readMagneticMapPcd(const fs::path& file) {
  if (!fs::exists(file)) throw InputError(file.string(), 0, "file not found");
  if (!fs::is_regular_file(file)) throw InputError(file.string(), 0, "is not a regular file");
  const io_detail::PcdHeader header = io_detail::readPcdHeader(file);
  for (const char* required : {"x", "y", "bh", "bv", "bf"})
    if (std::find(header.fields.begin(), header.fields.end(), required) == header.fields.end())
      throw InputError(
          file.string(), 0,
          std::string("has no field '") + required + "'; a magnetic map needs x y bh bv bf");
  std::optional<GridGeometry> grid;
  for (const auto& [line, text] : header.comments)
    if (text.compare(0, std::strlen(kGridTag), kGridTag) == 0)
      grid = parseGridComment(text.substr(std::strlen(kGridTag)), line, file);
  if (grid) checkGridFits(*grid, static_cast<std::size_t>(header.declaredPoints()), file);
  if (header.declaredPoints() == 0) {
    if (!grid) return MagneticMap{};
    return emptyMap(*grid);
  }

  const pcl::PCLPointCloud2 blob = io_detail::readPcdBlob(file);
  std::array<std::vector<double>, 5> fingerprint;  // bh bv bf, then x y
  const char* names[] = {"bh", "bv", "bf", "x", "y"};
  for (int c = 0; c < 5; ++c) {
    auto values = column(blob, names[c], file);
    if (!values) throw InputError(file.string(), 0, std::string("has no field '") + names[c] + "'");
    fingerprint[c] = std::move(*values);
  }
  const auto z = column(blob, "z", file);
  const auto bx = column(blob, "bx", file);
  const auto by = column(blob, "by", file);
  const std::vector<double>& x = fingerprint[3];
  const std::vector<double>& y = fingerprint[4];
  for (std::size_t p = 0; p < x.size(); ++p)
    for (int c = 0; c < 5; ++c)
      if (!std::isfinite(fingerprint[c][p]))
        throw InputError(file.string(), 0,
                         "point " + std::to_string(p) + " has a non-finite " + names[c]);
  if (!grid) {
    grid = inferGrid(x, y, z, file);
    checkGridFits(*grid, x.size(), file);
  }

  MagneticMap map = emptyMap(*grid);
  for (std::size_t p = 0; p < x.size(); ++p) {
    const std::size_t i = cellOf(map, x[p], y[p], p, file);
    if (!std::isnan(map.total_uT[i]))
      throw InputError(file.string(), 0,
                       "point " + std::to_string(p) + " repeats the cell of an earlier point");
    map.horizontal_uT[i] = static_cast<float>(fingerprint[0][p]);
    map.vertical_uT[i] = static_cast<float>(fingerprint[1][p]);
    map.total_uT[i] = static_cast<float>(fingerprint[2][p]);
    map.session_x_uT[i] = bx ? static_cast<float>((*bx)[p]) : kNaN;
    map.session_y_uT[i] = by ? static_cast<float>((*by)[p]) : kNaN;
  }
  return map;
}

void writeChangeMapPcd(const fs::path& file, const ChangeMap& map) {
  const std::size_t cells = static_cast<std::size_t>(std::max(0, map.width)) *
                            static_cast<std::size_t>(std::max(0, map.height));
  if (map.pairs.size() != cells || map.chi2.size() != cells || map.delta_uT.size() != cells ||
      map.region.size() != cells)
    throw std::invalid_argument("writeChangeMapPcd: the map's cells do not match its " +
                                std::to_string(map.width) + " x " + std::to_string(map.height) +
                                " grid");
  if (!(map.cell_size_m > 0.0) || !map.origin_m.allFinite() || !std::isfinite(map.height_m))
    throw std::invalid_argument("writeChangeMapPcd: invalid grid geometry");
  std::vector<std::size_t> compared;
  for (std::size_t i = 0; i < cells; ++i)
    if (map.pairs[i] > 0) compared.push_back(i);
  pcl::PCLPointCloud2 blob =
      floatBlob({"x", "y", "z", "delta", "chi2", "region", "pairs"}, compared.size());
  for (std::size_t k = 0; k < compared.size(); ++k) {
    const std::size_t i = compared[k];
    if (!std::isfinite(map.delta_uT[i]) || !std::isfinite(map.chi2[i]))
      throw std::invalid_argument("writeChangeMapPcd: compared cell " + std::to_string(i) +
                                  " has a non-finite value");
    const int ix = static_cast<int>(i % map.width), iy = static_cast<int>(i / map.width);
    putFloats(&blob, k,
              {static_cast<float>(map.origin_m.x() + (ix + 0.5) * map.cell_size_m),
               static_cast<float>(map.origin_m.y() + (iy + 0.5) * map.cell_size_m),
               static_cast<float>(map.height_m), map.delta_uT[i], map.chi2[i],
               static_cast<float>(map.region[i]), static_cast<float>(map.pairs[i])});
  }
  io_detail::writeFileAtomically(file, encodePcd(blob, gridComment(map), file));
}

ChangeMap readChangeMapPcd(const fs::path& file) {
  if (!fs::exists(file)) throw InputError(file.string(), 0, "file not found");
  if (!fs::is_regular_file(file)) throw InputError(file.string(), 0, "is not a regular file");
  const io_detail::PcdHeader header = io_detail::readPcdHeader(file);
  std::optional<GridGeometry> grid;
  for (const auto& [line, text] : header.comments)
    if (text.compare(0, std::strlen(kGridTag), kGridTag) == 0)
      grid = parseGridComment(text.substr(std::strlen(kGridTag)), line, file);
  if (!grid)
    throw InputError(
        file.string(), 0,
        "has no '# " + std::string(kGridTag) + "' comment: not a change map mm4mm wrote");
  checkGridFits(*grid, static_cast<std::size_t>(header.declaredPoints()), file);
  ChangeMap map;
  map.origin_m = grid->origin_m;
  map.cell_size_m = grid->cell_size_m;
  map.width = grid->width;
  map.height = grid->height;
  map.height_m = grid->height_m;
  const std::size_t cells = static_cast<std::size_t>(grid->width) * grid->height;
  map.pairs.assign(cells, 0);
  map.chi2.assign(cells, kNaN);
  map.delta_uT.assign(cells, kNaN);
  map.region.assign(cells, 0);
  if (header.declaredPoints() == 0) return map;

  const pcl::PCLPointCloud2 blob = io_detail::readPcdBlob(file);
  const char* names[] = {"x", "y", "delta", "chi2", "region", "pairs"};
  std::array<std::vector<double>, 6> columns;
  for (int c = 0; c < 6; ++c) {
    auto values = column(blob, names[c], file);
    if (!values)
      throw InputError(file.string(), 0,
                       std::string("has no field '") + names[c] +
                           "'; a change map needs x y delta chi2 region pairs");
    columns[c] = std::move(*values);
  }
  const MagneticMap cells_of = emptyMap(*grid);  // the grid's cell lookup
  for (std::size_t p = 0; p < columns[0].size(); ++p) {
    for (int c = 2; c < 6; ++c)
      if (!std::isfinite(columns[c][p]) || columns[c][p] < 0.0)
        throw InputError(
            file.string(), 0,
            "point " + std::to_string(p) + " has a non-finite or negative " + names[c]);
    const double region = columns[4][p], pairs = columns[5][p];
    if (region != std::floor(region) || region > 4e9 || pairs != std::floor(pairs) || pairs < 1.0 ||
        pairs > 65535.0)
      throw InputError(file.string(), 0,
                       "point " + std::to_string(p) +
                           ": region and pairs must be whole numbers (pairs at least 1)");
    const std::size_t i = cellOf(cells_of, columns[0][p], columns[1][p], p, file);
    if (map.pairs[i] != 0)
      throw InputError(file.string(), 0,
                       "point " + std::to_string(p) + " repeats the cell of an earlier point");
    map.delta_uT[i] = static_cast<float>(columns[2][p]);
    map.chi2[i] = static_cast<float>(columns[3][p]);
    map.region[i] = static_cast<std::uint32_t>(region);
    map.pairs[i] = static_cast<std::uint16_t>(pairs);
  }
  return map;
}

}  // namespace mm4mm
