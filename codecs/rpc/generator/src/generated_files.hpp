// Writing a generator's files (the service code, the typed clients): one place for the folder's creation
// and the write errors; the files nanopb writes code of.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace google::protobuf {
class FileDescriptor;
}

namespace tether::rpc {

/// False for the imports that only carry options (nanopb's, protobuf's own descriptors): nanopb writes no
/// code of them.
bool carries_code(const std::string& file);

/// Appends `file` and every file it imports, transitively, dependencies first, each once.
void collect_files(const google::protobuf::FileDescriptor& file, std::vector<const google::protobuf::FileDescriptor*>& files);

/// Writes each (file name, text) into `directory` (created); returns the paths written. Throws
/// std::runtime_error naming the folder or the file that cannot be written.
std::vector<std::filesystem::path> write_generated_files(
    const std::filesystem::path& directory, const std::vector<std::pair<std::string, const std::string*>>& files);

}  // namespace tether::rpc
