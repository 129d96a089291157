// Capture files of the command tests: a fresh name in the test's temporary folder, and a file read back.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tether/transports/pcapng.hpp"

namespace tether::cli::testing {

/// `<temporary folder>/<stem>.pcapng`, removed first.
inline std::string fresh_capture_file(const std::string& stem) {
  const std::filesystem::path file = std::filesystem::path(::testing::TempDir()) / (stem + ".pcapng");
  std::filesystem::remove(file);
  return file.string();
}

/// The capture in `file` (a test failure with the reader's message, and an empty capture, when it is not one).
inline transports::Capture read_capture_file(const std::string& file) {
  boost::system::error_code error;
  std::string message;
  const auto capture = transports::read_capture(file, error, message);
  EXPECT_TRUE(capture) << message;
  return capture ? *capture : transports::Capture();
}

}  // namespace tether::cli::testing
