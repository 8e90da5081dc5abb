#pragma once
// What every fuzz target shares: the readers take file paths, so each input is written to a file
// of a scratch directory of this process, and the reader run on it. A reader may refuse the input
// only the way the command line reports bad input (InputError or std::invalid_argument, exit 2);
// any other exception escapes and libFuzzer reports it as a crash, like ASan and UBSan findings.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm::fuzz {

inline const std::filesystem::path& scratchDirectory() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path d =
        std::filesystem::temp_directory_path() / ("mm4mm_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline void writeInput(const std::filesystem::path& file, const std::uint8_t* data,
                       std::size_t size) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

// Runs `read` and swallows the refusals the CLI turns into exit code 2.
template <typename Read>
void expectReadOrRefusal(Read&& read) {
  try {
    read();
  } catch (const InputError&) {
  } catch (const std::invalid_argument&) {
  }
}

}  // namespace mm4mm::fuzz
