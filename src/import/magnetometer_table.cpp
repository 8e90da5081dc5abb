#include "mm4mm/import/magnetometer_table.hpp"

#include <algorithm>
#include <charconv>
#include <stdexcept>

#include "../io/text_io.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

std::vector<std::string> splitCells(std::string_view line, char delimiter) {
  std::vector<std::string> cells;
  if (delimiter == ' ') {
    for (std::string_view token : io_detail::splitWhitespace(line)) cells.emplace_back(token);
    return cells;
  }
  std::size_t begin = 0;
  while (true) {
    const std::size_t end = line.find(delimiter, begin);
    cells.emplace_back(io_detail::trim(line.substr(begin, end - begin)));
    if (end == std::string_view::npos) break;
    begin = end + 1;
  }
  return cells;
}

char delimiterOf(std::string_view line) {
  for (char c : {',', ';', '\t'})
    if (line.find(c) != std::string_view::npos) return c;
  return ' ';
}

std::optional<std::size_t> indexOf(const std::string& column) {
  std::size_t index = 0;
  const auto result = std::from_chars(column.data(), column.data() + column.size(), index);
  if (result.ec != std::errc() || result.ptr != column.data() + column.size()) return std::nullopt;
  return index;
}

}  // namespace

void parseColumnMap(const std::string& text, MagnetometerTableOptions* options) {
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string pair = text.substr(begin, end - begin);
    const std::size_t eq = pair.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == pair.size())
      throw std::invalid_argument("column map '" + text + "': '" + pair +
                                  "' is not KEY=COLUMN (keys t, x, y, z)");
    const std::string key = pair.substr(0, eq);
    const std::string column = pair.substr(eq + 1);
    if (key == "t")
      options->time_column = column;
    else if (key == "x")
      options->x_column = column;
    else if (key == "y")
      options->y_column = column;
    else if (key == "z")
      options->z_column = column;
    else
      throw std::invalid_argument("column map '" + text + "': unknown key '" + key +
                                  "' (keys t, x, y, z)");
    begin = end + 1;
  }
}

MagnetometerRecording readMagnetometerTable(const std::filesystem::path& file,
                                            const MagnetometerTableOptions& options) {
  const std::string content = io_detail::readWholeFile(file);
  const std::string name = file.string();
  const std::vector<std::string> wanted = {options.time_column, options.x_column, options.y_column,
                                           options.z_column};
  const bool by_index = std::all_of(wanted.begin(), wanted.end(),
                                    [](const std::string& c) { return indexOf(c).has_value(); });
  MagnetometerRecording recording;
  recording.source = name;
  recording.read_as = options.unit;
  std::vector<std::size_t> columns;
  char delimiter = 0;
  const double scale = microTeslaPer(options.unit);
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty() || text.front() == '#') return;
    if (line == 1 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 BOM
    if (delimiter == 0) {
      delimiter = delimiterOf(text);
      const std::vector<std::string> header = splitCells(text, delimiter);
      const bool numeric_first = !header.empty() && indexOf(header[0]).has_value();
      if (by_index) {
        for (const std::string& c : wanted) columns.push_back(*indexOf(c));
        const bool looks_numeric =
            !header.empty() && header[0].find_first_not_of("0123456789.-+eE") == std::string::npos;
        if (!looks_numeric && !numeric_first) return;  // a header row, skipped
      } else {
        for (const std::string& c : wanted) {
          const auto it = std::find(header.begin(), header.end(), c);
          if (it == header.end()) {
            std::string present;
            for (const std::string& h : header) present += (present.empty() ? "" : ", ") + h;
            throw InputError(name, line, "has no column '" + c + "'; its header: " + present);
          }
          columns.push_back(static_cast<std::size_t>(it - header.begin()));
        }
        return;
      }
    }
    const std::vector<std::string> cells = splitCells(text, delimiter);
    const std::size_t needed = *std::max_element(columns.begin(), columns.end()) + 1;
    if (cells.size() < needed)
      throw InputError(name, line,
                       "has " + std::to_string(cells.size()) + " cells, the columns need " +
                           std::to_string(needed));
    MagnetometerSample sample;
    sample.time_s = options.seconds_per_time_unit *
                    io_detail::parseFiniteNumber(cells[columns[0]], "time", name, line);
    for (int k = 0; k < 3; ++k)
      sample.field_body_uT[k] =
          scale * io_detail::parseFiniteNumber(cells[columns[1 + k]], "field", name, line);
    if (!sample.field_body_uT.allFinite())
      throw InputError(name, line, "the field overflows in " + unitName(options.unit));
    if (!recording.samples.empty() && sample.time_s < recording.samples.back().time_s)
      throw InputError(name, line, "times go backwards");
    recording.samples.push_back(sample);
  });
  if (recording.samples.empty()) throw InputError(name, 0, "holds no sample row");
  return recording;
}

}  // namespace mm4mm
