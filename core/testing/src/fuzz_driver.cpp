// Runs a libFuzzer-style target without libFuzzer (any compiler): every file of the corpus folders given
// on the command line (in name order), then seeded random inputs and mutations of the corpus. On an abort,
// the input is written to ./fuzz-crash-<seed> so it can be added to the target's corpus archive as a
// regression (tools/fuzz add NAME FILE).
//   usage: <target> [--iterations N] [corpus folders...]    (RANDOM_SEED replays a run)
#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "tether/testing/random_seed.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

std::vector<uint8_t> current_input;

void run(const std::vector<uint8_t>& input) {
  current_input = input;
  LLVMFuzzerTestOneInput(input.data(), input.size());
}

void save_current_input() {
  const std::string name = "fuzz-crash-" + std::to_string(tether::testing::random_seed());
  std::ofstream(name, std::ios::binary).write(reinterpret_cast<const char*>(current_input.data()),
                                              static_cast<std::streamsize>(current_input.size()));
  std::fprintf(stderr, "fuzz driver: failing input written to %s\n", name.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  long iterations = 20000;
  std::vector<std::vector<uint8_t>> corpus;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--iterations" && i + 1 < argc) {
      iterations = std::stol(argv[++i]);
      continue;
    }
    // In name order, not the directory's: the mutations below pick corpus entries by index, so RANDOM_SEED
    // replays the same inputs whatever filesystem or build folder the corpus was unpacked into.
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(arg)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    for (const auto& path : files) {
      std::ifstream file(path, std::ios::binary);
      corpus.emplace_back(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
    }
  }
  std::signal(SIGABRT, [](int) {
    save_current_input();
    std::_Exit(134);
  });
  for (const auto& input : corpus) run(input);
  auto random = tether::testing::seeded_generator(0xF022);
  std::uniform_int_distribution<int> byte(0, 255);
  for (long n = 0; n < iterations; ++n) {
    std::vector<uint8_t> input;
    if (!corpus.empty() && n % 2 == 0) {
      // Mutate a corpus entry: flip, insert, erase, splice with another entry.
      input = corpus[random() % corpus.size()];
      const int edits = 1 + static_cast<int>(random() % 8);
      for (int e = 0; e < edits; ++e) {
        const size_t at = input.empty() ? 0 : random() % input.size();
        switch (random() % 4) {
          case 0: if (!input.empty()) input[at] = static_cast<uint8_t>(input[at] ^ (1u << (random() % 8))); break;
          case 1: input.insert(input.begin() + static_cast<std::ptrdiff_t>(at), static_cast<uint8_t>(byte(random))); break;
          case 2: if (!input.empty()) input.erase(input.begin() + static_cast<std::ptrdiff_t>(at)); break;
          default: {
            const auto& other = corpus[random() % corpus.size()];
            input.insert(input.begin() + static_cast<std::ptrdiff_t>(at), other.begin(), other.end());
          }
        }
      }
    } else {
      input.resize(random() % 300);
      for (auto& b : input) b = static_cast<uint8_t>(byte(random));
    }
    run(input);
  }
  std::printf("fuzz driver: %zu corpus inputs and %ld generated inputs passed\n", corpus.size(), iterations);
  return 0;
}
