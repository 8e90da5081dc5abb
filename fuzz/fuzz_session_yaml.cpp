// session.yaml: id and sensor rig.
#include "fuzz_input.hpp"
#include "io/session_yaml.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "session.yaml";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::Session session;
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::io_detail::readSessionYaml(file, &session); });
  return 0;
}
