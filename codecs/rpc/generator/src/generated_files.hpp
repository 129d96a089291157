// Writing a generator's files (the service code, the typed clients): one place for the folder's creation
// and the write errors.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace tether::rpc {

/// Writes each (file name, text) into `directory` (created); returns the paths written. Throws
/// std::runtime_error naming the folder or the file that cannot be written.
std::vector<std::filesystem::path> write_generated_files(
    const std::filesystem::path& directory, const std::vector<std::pair<std::string, const std::string*>>& files);

}  // namespace tether::rpc
