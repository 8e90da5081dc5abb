#pragma once
// SHA-256 of files (OpenSSL), for the atlas manifest's record of what it lists.

#include <filesystem>
#include <string>

namespace mm4mm::io_detail {

/// Lower-case hex SHA-256 of the file's bytes. Throws std::runtime_error when it cannot be read.
std::string sha256OfFile(const std::filesystem::path& file);

}  // namespace mm4mm::io_detail
