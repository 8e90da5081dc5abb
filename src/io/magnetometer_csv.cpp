#include "magnetometer_csv.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

namespace {

// The Earth's field is about 25–65 µT and steel nearby adds tens of µT; a reading above this is
// a unit mix-up (nT, gauss) or a broken sensor, not a field.
constexpr double kMaxField_uT = 1000.0;
constexpr std::array<const char*, 5> kCsvColumns = {"t", "sensor", "bx", "by", "bz"};

// Splits at commas into `fields` (at most 5 kept); returns the number of fields on the line.
std::size_t splitCsv(std::string_view row, std::array<std::string_view, 5>* fields) {
  std::size_t count = 0;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = row.find(',', begin);
    const std::size_t end = comma == std::string_view::npos ? row.size() : comma;
    if (count < fields->size()) (*fields)[count] = trim(row.substr(begin, end - begin));
    ++count;
    if (comma == std::string_view::npos) return count;
    begin = comma + 1;
  }
}

class CsvRowParser {
 public:
  CsvRowParser(const fs::path& file, int sensors) : file_(file.string()), sensors_(sensors) {}

  MagnetometerSample parse(std::string_view row, int line) {
    line_ = line;
    std::array<std::string_view, 5> fields;
    const std::size_t count = splitCsv(row, &fields);
    if (count != fields.size())
      fail("expected 5 values (t,sensor,bx,by,bz), got " + std::to_string(count));
    MagnetometerSample sample;
    sample.time_s = number(fields[0], kCsvColumns[0]);
    sample.sensor = sensor(fields[1]);
    for (int k = 0; k < 3; ++k) sample.field_body_uT[k] = number(fields[2 + k], kCsvColumns[2 + k]);
    const double magnitude = sample.field_body_uT.norm();
    if (magnitude > kMaxField_uT)
      fail("field magnitude " + formatNumber(magnitude) +
           " µT is absurd (over 1000 µT; the Earth's field is about 50 µT)");
    return sample;
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_, line_, problem);
  }

 private:
  double number(std::string_view token, const char* name) const {
    return parseFiniteNumber(token, name, file_, line_);
  }

  int sensor(std::string_view token) const {
    int value = 0;
    const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
    if (result.ec != std::errc() || result.ptr != token.data() + token.size())
      fail("sensor index '" + std::string(token) + "' is not an integer");
    if (value < 0 || value >= sensors_)
      fail("sensor index " + std::to_string(value) + " is not in session.yaml's " +
           std::to_string(sensors_) + " magnetometers");
    return value;
  }

  std::string file_;
  int sensors_;
  int line_ = 0;
};

void checkCsvHeader(std::string_view text, int line, const fs::path& file) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 byte order mark
  std::array<std::string_view, 5> fields;
  bool matches = splitCsv(text, &fields) == fields.size();
  for (std::size_t i = 0; matches && i < fields.size(); ++i) matches = fields[i] == kCsvColumns[i];
  if (!matches)
    throw InputError(file.string(), line,
                     "header is '" + std::string(text) + "', expected 't,sensor,bx,by,bz'");
}

}  // namespace

std::vector<MagnetometerSample> readMagnetometerCsv(const fs::path& file, int sensors) {
  const std::string content = readWholeFile(
      file, "every session needs one (a header alone for a session without magnetometer data)");
  std::vector<MagnetometerSample> samples;
  samples.reserve(std::count(content.begin(), content.end(), '\n'));
  CsvRowParser parser(file, sensors);
  bool has_header = false;
  double previous_time = -std::numeric_limits<double>::infinity();
  std::vector<double> last_time(sensors, -std::numeric_limits<double>::infinity());
  std::vector<int> last_line(sensors, 0);
  forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    if (!has_header) {
      checkCsvHeader(text, line, file);
      has_header = true;
      return;
    }
    const MagnetometerSample sample = parser.parse(text, line);
    if (sample.time_s < previous_time)
      parser.fail("time " + formatNumber(sample.time_s) + " is before the previous row's " +
                  formatNumber(previous_time));
    if (sample.time_s == last_time[sample.sensor])
      parser.fail("duplicate sample: sensor " + std::to_string(sample.sensor) +
                  " already has one at time " + formatNumber(sample.time_s) + " (line " +
                  std::to_string(last_line[sample.sensor]) + ")");
    previous_time = last_time[sample.sensor] = sample.time_s;
    last_line[sample.sensor] = line;
    samples.push_back(sample);
  });
  if (!has_header)
    throw InputError(file.string(), 0, "is empty; expected the header 't,sensor,bx,by,bz'");
  // Rows at one time may list the sensors in any order; Session promises ties by sensor index.
  const auto by_time_then_sensor = [](const MagnetometerSample& a, const MagnetometerSample& b) {
    return a.time_s < b.time_s || (a.time_s == b.time_s && a.sensor < b.sensor);
  };
  if (!std::is_sorted(samples.begin(), samples.end(), by_time_then_sensor))
    std::stable_sort(samples.begin(), samples.end(), by_time_then_sensor);
  return samples;
}

std::string formatMagnetometerCsv(const std::vector<MagnetometerSample>& samples, int sensors) {
  const auto fail = [](std::size_t i, const std::string& problem) {
    throw std::invalid_argument("writeSession: magnetometer sample " + std::to_string(i) + " " +
                                problem);
  };
  std::string out = "t,sensor,bx,by,bz\n";
  out.reserve(out.size() + samples.size() * 48);
  // Compare times as they will read back (1 µs), so that the file passes readSession's checks.
  double previous_time = -std::numeric_limits<double>::infinity();
  std::vector<double> last_time(sensors, -std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const MagnetometerSample& s = samples[i];
    if (s.sensor < 0 || s.sensor >= sensors) fail(i, "has a sensor index outside the rig");
    if (!std::isfinite(s.time_s) || !s.field_body_uT.allFinite()) fail(i, "is not finite");
    if (s.field_body_uT.norm() > kMaxField_uT) fail(i, "has a field above 1000 µT");
    const std::size_t row_begin = out.size();
    appendFixed(s.time_s, 6, &out);
    double time = 0.0;
    std::from_chars(out.data() + row_begin, out.data() + out.size(), time);
    if (time < previous_time) fail(i, "is earlier than the one before (samples must be sorted)");
    if (time == last_time[s.sensor]) fail(i, "repeats its sensor's time (to 1 µs)");
    previous_time = last_time[s.sensor] = time;
    out += ',';
    out += std::to_string(s.sensor);
    for (int k = 0; k < 3; ++k) {
      out += ',';
      appendFixed(s.field_body_uT[k], 4, &out);
    }
    out += '\n';
  }
  return out;
}

}  // namespace mm4mm::io_detail
