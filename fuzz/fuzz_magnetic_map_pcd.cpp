// magnetic_map.pcd: a magnetic map grid as a PCD with its own fields.
#include "fuzz_input.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "magnetic_map.pcd";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readMagneticMapPcd(file); });
  return 0;
}
