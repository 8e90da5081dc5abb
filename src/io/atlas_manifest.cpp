#include "atlas_manifest.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "checksum.hpp"
#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace io_detail {

namespace fs = std::filesystem;

fs::path normalAtlasPath(const fs::path& dir) {
  fs::path normal = fs::absolute(dir).lexically_normal();
  if (!normal.has_filename()) normal = normal.parent_path();
  return normal;
}

fs::path previousAtlasPath(const fs::path& dir) {
  fs::path previous = normalAtlasPath(dir);
  previous += ".previous";
  return previous;
}

namespace {

YAML::Node matrixYaml(const Eigen::Isometry3d& T) {
  YAML::Node rows(YAML::NodeType::Sequence);
  for (int r = 0; r < 4; ++r) {
    YAML::Node row(YAML::NodeType::Sequence);
    row.SetStyle(YAML::EmitterStyle::Flow);
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

std::string manifestYaml(const std::vector<Session>& sessions, const std::vector<fs::path>& sources,
                         const MergeResult& result,
                         const std::vector<std::pair<std::string, std::string>>& checksums) {
  YAML::Node root;
  root["version"] = kManifestVersion;
  root["frame"] = sessions.at(result.frame_session).id;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    YAML::Node entry;
    entry["id"] = sessions[s].id;
    entry["source"] = fs::absolute(sources[s]).lexically_normal().string();
    entry["connected"] = static_cast<bool>(result.solution.connected[s]);
    entry["T_atlas_session"] = matrixYaml(result.solution.T_atlas_session[s]);
    root["sessions"].push_back(entry);
  }
  for (const auto& [file, sha256] : checksums) root["files"][file] = sha256;
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

std::string manifestWithFiles(const std::string& manifest_text,
                              const std::vector<std::pair<std::string, std::string>>& checksums) {
  YAML::Node root = YAML::Load(manifest_text);
  YAML::Node files(YAML::NodeType::Map);
  for (const auto& [file, sha256] : checksums) files[file] = sha256;
  root["files"] = files;
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

std::vector<std::string> filesOf(const fs::path& dir) {
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string relative = fs::relative(entry.path(), dir).generic_string();
    if (relative != "atlas.yaml") files.push_back(relative);
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::pair<std::string, std::string>> checksumsOf(const fs::path& dir) {
  std::vector<std::pair<std::string, std::string>> checksums;
  for (const std::string& file : filesOf(dir))
    checksums.emplace_back(file, sha256OfFile(dir / file));
  return checksums;
}

}  // namespace io_detail

namespace fs = std::filesystem;
using io_detail::filesOf;
using io_detail::kConfigFile;
using io_detail::kManifestVersion;
using io_detail::kManifestVersionWithoutConfig;
using io_detail::normalAtlasPath;
using io_detail::previousAtlasPath;
using io_detail::readWholeFile;
using io_detail::sha256OfFile;

namespace {

// The largest atlas.yaml, config.yaml or report.json read (bytes): each is parsed whole, so a
// larger one is refused before it is read. A 3-session merge writes a 40 KiB report, 2.3 KiB per
// pair; all 45 000 pairs of 300 sessions would make about 100 MiB.
constexpr std::uintmax_t kMaxParsedFileBytes = std::uintmax_t{256} << 20;

// An atlas is read and written within its own directory: neither it nor anything in it may be a
// symbolic link, which would point the reader (or a later add's writer) outside it.
void checkNoLink(const fs::path& dir, const fs::path& relative, const std::string& manifest,
                 int line) {
  fs::path path = dir;
  for (const fs::path& part : relative) {
    path /= part;
    if (fs::is_symlink(path))
      throw InputError(manifest, line,
                       (path.lexically_relative(dir)).generic_string() +
                           " is a symbolic link (to " + fs::read_symlink(path).string() +
                           "): an atlas holds its own files, and none is read through a link");
  }
}

void checkParsedSize(const fs::path& file, const std::string& manifest, int line) {
  const std::uintmax_t bytes = fs::file_size(file);
  if (bytes > kMaxParsedFileBytes)
    throw InputError(manifest, line,
                     file.filename().string() + " is " + std::to_string(bytes >> 20) +
                         " MiB; an atlas's " + file.filename().string() + " is read whole, up to " +
                         std::to_string(kMaxParsedFileBytes >> 20) + " MiB");
}

bool parsedWhole(const std::string& file) { return file == "report.json" || file == kConfigFile; }

}  // namespace

AtlasManifest readAtlasManifest(const fs::path& dir) {
  const fs::path file = dir / "atlas.yaml";
  const std::string name = file.string();
  const fs::path atlas_dir = normalAtlasPath(dir);
  if (fs::is_symlink(atlas_dir))
    throw InputError(dir.string(), 0,
                     "is a symbolic link (to " + fs::read_symlink(atlas_dir).string() +
                         "): give the atlas directory itself, which is read and written in "
                         "place");
  checkNoLink(dir, "atlas.yaml", name, 0);
  if (!fs::exists(file)) {
    const fs::path previous = previousAtlasPath(dir);
    if (fs::exists(previous / "atlas.yaml"))
      throw InputError(dir.string(), 0,
                       "no atlas here, but an interrupted write left the previous atlas at " +
                           previous.string() + ": rename it back to " + dir.string());
    throw InputError(dir.string(), 0, "not an atlas directory (no atlas.yaml)");
  }
  checkParsedSize(file, name, 0);
  const std::string content = readWholeFile(file);
  YAML::Node root;
  try {
    root = YAML::Load(content);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.line + 1, std::string("not valid YAML: ") + e.msg);
  }
  // Every field read names itself in the error, with the line of its parent.
  const auto field = [&](const YAML::Node& parent, const char* key, const std::string& where) {
    // yaml-cpp throws on a subscript of a scalar or a list: a corrupt manifest, said as such.
    if (!parent.IsMap())
      throw InputError(name, parent.Mark().line + 1,
                       where + "expected a map holding '" + key + "'");
    const YAML::Node value = parent[key];
    if (!value)
      throw InputError(name, parent.Mark().line + 1, where + "missing field '" + key + "'");
    return value;
  };
  const auto as = [&](const YAML::Node& value, const std::string& what, auto example) {
    try {
      return value.as<decltype(example)>();
    } catch (const YAML::Exception&) {
      throw InputError(name, value.Mark().line + 1, what + " is malformed");
    }
  };
  AtlasManifest manifest;
  manifest.version = as(field(root, "version", ""), "'version'", 0);
  if (manifest.version != kManifestVersion && manifest.version != kManifestVersionWithoutConfig)
    throw InputError(name, 0,
                     "version " + std::to_string(manifest.version) + " is not supported (" +
                         std::to_string(kManifestVersionWithoutConfig) + " and " +
                         std::to_string(kManifestVersion) +
                         " are; an atlas of version 1 has no checksums: merge it again)");
  // Before configs were stored the manifest kept the one setting `add` had to reuse.
  manifest.config_stored = manifest.version == kManifestVersion;
  if (!manifest.config_stored)
    manifest.config.outputs.octomap.resolution_m =
        as(field(field(root, "settings", ""), "octomap_resolution_m", "settings: "),
           "'settings.octomap_resolution_m'", 0.0);
  const YAML::Node sessions = field(root, "sessions", "");
  if (!sessions.IsSequence() || sessions.size() == 0)
    throw InputError(name, sessions.Mark().line + 1, "'sessions' must be a non-empty list");
  for (const YAML::Node& node : sessions) {
    AtlasSessionEntry entry;
    entry.id = as(field(node, "id", "a session: "), "'id'", std::string());
    const std::string where = "session '" + entry.id + "': ";
    if (entry.id.empty() || entry.id.find('/') != std::string::npos || entry.id == "." ||
        entry.id == "..")
      throw InputError(name, node.Mark().line + 1, where + "the id must be a plain name");
    entry.source = as(field(node, "source", where), where + "'source'", std::string());
    entry.connected = as(field(node, "connected", where), where + "'connected'", false);
    const YAML::Node T = field(node, "T_atlas_session", where);
    if (!T.IsSequence() || T.size() != 4)
      throw InputError(name, T.Mark().line + 1, where + "T_atlas_session must be 4 rows");
    for (int r = 0; r < 4; ++r) {
      if (!T[r].IsSequence() || T[r].size() != 4)
        throw InputError(
            name, T[r].Mark().line + 1,
            where + "T_atlas_session row " + std::to_string(r + 1) + " must hold 4 numbers");
      for (int c = 0; c < 4; ++c)
        entry.T_atlas_session.matrix()(r, c) =
            as(T[r][c], where + "T_atlas_session row " + std::to_string(r + 1), 0.0);
    }
    manifest.sessions.push_back(entry);
  }
  if (const YAML::Node frame = root["frame"]) {
    const std::string id = as(frame, "'frame'", std::string());
    const auto found = std::find_if(manifest.sessions.begin(), manifest.sessions.end(),
                                    [&](const AtlasSessionEntry& entry) { return entry.id == id; });
    if (found == manifest.sessions.end())
      throw InputError(name, frame.Mark().line + 1,
                       "'frame' names session '" + id + "', which is not in 'sessions'");
    manifest.frame_session = static_cast<int>(found - manifest.sessions.begin());
  }
  if (!manifest.sessions[manifest.frame_session].connected)
    throw InputError(name, 0,
                     "session '" + manifest.sessions[manifest.frame_session].id +
                         "', whose frame is the atlas's, is marked unconnected (a corrupt "
                         "manifest)");
  const YAML::Node files = field(root, "files", "");
  if (!files.IsMap()) throw InputError(name, files.Mark().line + 1, "'files' must be a map");
  for (const auto& item : files) {
    const std::string file = as(item.first, "a file name in 'files'", std::string());
    const std::string sha256 = as(item.second, "the checksum of " + file, std::string());
    const int line = item.first.Mark().line + 1;
    // Names stay inside the atlas: a manifest must not point the reader elsewhere.
    const fs::path relative(file);
    if (file.empty() || relative.is_absolute() ||
        std::any_of(relative.begin(), relative.end(),
                    [](const fs::path& part) { return part == ".."; }))
      throw InputError(name, line, "'" + file + "' is not a file of the atlas");
    checkNoLink(dir, relative, name, line);
    if (!fs::is_regular_file(dir / file))
      throw InputError(name, line,
                       "lists " + file + ", which is missing (a corrupt or half-written atlas)");
    if (parsedWhole(file)) checkParsedSize(dir / file, name, line);
    if (sha256OfFile(dir / file) != sha256)
      throw InputError(name, line,
                       file + " does not match its checksum (a corrupt or half-written atlas)");
    manifest.files.emplace_back(file, sha256);
  }
  // A manifest cut short lists fewer files than the atlas holds.
  for (const std::string& file : filesOf(dir))
    if (std::none_of(manifest.files.begin(), manifest.files.end(),
                     [&](const auto& listed) { return listed.first == file; }))
      throw InputError(name, 0,
                       file + " is not listed in 'files' (a corrupt or half-written manifest)");
  if (manifest.config_stored) {
    if (std::none_of(manifest.files.begin(), manifest.files.end(),
                     [](const auto& listed) { return listed.first == kConfigFile; }))
      throw InputError(name, 0,
                       std::string("lists no ") + kConfigFile +
                           ", the settings the atlas was built with (a corrupt manifest)");
    // Written by writeAtlas and checked against its checksum above; the command that uses it
    // validates it with whatever overrides it.
    manifest.config = parsePipelineConfig(readWholeFile(dir / kConfigFile),
                                          (dir / kConfigFile).string(), {}, nullptr);
  }
  return manifest;
}

}  // namespace mm4mm
