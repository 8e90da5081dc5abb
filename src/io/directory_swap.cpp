#include "directory_swap.hpp"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <system_error>
#include <vector>

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

void syncPath(const fs::path& path, bool directory) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | (directory ? O_DIRECTORY : 0));
  if (fd < 0 || ::fsync(fd) != 0) {
    const std::error_code error(errno, std::generic_category());
    if (fd >= 0) ::close(fd);
    throw fs::filesystem_error("cannot flush to disk", path, error);
  }
  ::close(fd);
}

void syncTree(const fs::path& dir) {
  std::vector<fs::path> directories{dir};
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_directory())
      directories.push_back(entry.path());
    else if (entry.is_regular_file())
      syncPath(entry.path(), false);
  }
  for (const fs::path& directory : directories) syncPath(directory, true);
}

void swapIntoPlace(const fs::path& staging, const fs::path& target, const fs::path& previous) {
  if (!fs::exists(fs::symlink_status(target))) {
    fs::rename(staging, target);
    syncPath(target.parent_path(), true);
    return;
  }
  if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
    syncPath(target.parent_path(), true);
    std::error_code ignored;
    fs::remove_all(staging, ignored);  // now the old directory
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
    throw fs::filesystem_error("cannot swap the new directory into place", staging, target,
                               std::error_code(errno, std::generic_category()));
  // A previous directory left by a write killed after its second rename: `target` is whole.
  if (fs::exists(previous)) fs::remove_all(previous);
  fs::rename(target, previous);
  try {
    fs::rename(staging, target);
  } catch (...) {
    std::error_code ignored;
    fs::rename(previous, target, ignored);  // the old one back in place
    throw;
  }
  syncPath(target.parent_path(), true);
  std::error_code ignored;
  fs::remove_all(previous, ignored);
}

void removeStaleStaging(const fs::path& target, const std::string& suffix) {
  const std::string prefix = target.filename().string() + suffix;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(target.parent_path(), error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && name.size() > prefix.size() &&
        name.size() - prefix.size() <= 9 &&
        std::all_of(name.begin() + prefix.size(), name.end(),
                    [](unsigned char c) { return std::isdigit(c) != 0; })) {
      const pid_t pid = static_cast<pid_t>(std::stol(name.substr(prefix.size())));
      if (::kill(pid, 0) == 0 || errno != ESRCH) continue;
      std::error_code ignored;
      fs::remove_all(entry.path(), ignored);
    }
  }
}

}  // namespace mm4mm::io_detail
