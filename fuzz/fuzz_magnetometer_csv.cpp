// magnetometer.csv for a rig of three magnetometers.
#include "fuzz_input.hpp"
#include "io/magnetometer_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "magnetometer.csv";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::io_detail::readMagnetometerCsv(file, 3); });
  return 0;
}
