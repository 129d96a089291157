#include "Console.h"

#include <cstdio>
#include <string>

namespace romiserial {

void Console::error(const char* format, ...) {
  va_list arguments;
  va_start(arguments, format);
  print("error", format, arguments);
  va_end(arguments);
}

void Console::warn(const char* format, ...) {
  va_list arguments;
  va_start(arguments, format);
  print("warning", format, arguments);
  va_end(arguments);
}

void Console::debug(const char* format, ...) {
  va_list arguments;
  va_start(arguments, format);
  print("debug", format, arguments);
  va_end(arguments);
}

void Console::print(const char* level, const char* format, va_list arguments) {
  char text[512];
  const int length = std::vsnprintf(text, sizeof text, format, arguments);
  if (length < 0) return;
  // One fputs per line: stdio locks the stream per call, so lines of several threads stay whole.
  std::string line = std::string(level) + ": " + text + (static_cast<std::size_t>(length) >= sizeof text ? "...\n" : "\n");
  std::fputs(line.c_str(), stderr);
}

}  // namespace romiserial
