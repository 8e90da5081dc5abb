#pragma once
// Internal to src/io: an atlas's manifest (atlas.yaml) and the paths around an atlas directory.
// readAtlasManifest (atlas_io.hpp) reads and checks the manifest.

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm::io_detail {

/// 2: the manifest lists every other file of the atlas with its SHA-256. 3: the settings the
/// atlas was built with are in config.yaml (listed like the others), not in the manifest.
constexpr int kManifestVersion = 3;
constexpr int kManifestVersionWithoutConfig = 2;
constexpr const char* kConfigFile = "config.yaml";

/// The atlas directory as an absolute path without a trailing separator ("atlas/" names
/// "atlas"), so that the names built beside it (.lock, .partial<pid>, .previous) are siblings.
std::filesystem::path normalAtlasPath(const std::filesystem::path& dir);

/// Where a write that cannot swap directories moves the old atlas meanwhile.
std::filesystem::path previousAtlasPath(const std::filesystem::path& dir);

/// atlas.yaml's text for the atlas of `result` over `sessions`, read from `sources`, whose
/// other files have `checksums`.
std::string manifestYaml(const std::vector<Session>& sessions,
                         const std::vector<std::filesystem::path>& sources,
                         const MergeResult& result,
                         const std::vector<std::pair<std::string, std::string>>& checksums);

/// The manifest `manifest_text` (atlas.yaml as written) with its file list replaced by
/// `checksums`, everything else as it was: for a write that changes files but not the sessions.
std::string manifestWithFiles(const std::string& manifest_text,
                              const std::vector<std::pair<std::string, std::string>>& checksums);

/// Every file under `dir` but the manifest, by path relative to it, sorted.
std::vector<std::string> filesOf(const std::filesystem::path& dir);

/// The same with each file's SHA-256.
std::vector<std::pair<std::string, std::string>> checksumsOf(const std::filesystem::path& dir);

}  // namespace mm4mm::io_detail
