// `printable`: what a device sent, made safe for a terminal, byte class by byte class.
#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "cli_support.hpp"

namespace tether::cli::testing {
namespace {

using namespace std::string_view_literals;

TEST(Printable, AsciiTextAndValidUtf8PassUnchanged) {
  EXPECT_EQ(printable("motor: ready [1,2] \"x\" \\n"), "motor: ready [1,2] \"x\" \\n");
  EXPECT_EQ(printable("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x9a\x80"), "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x9a\x80");
}

TEST(Printable, ControlBytesAndDeleteAreEscaped) {
  EXPECT_EQ(printable("\x1b[2J\x07\r\n\t\x7f"sv), "\\x1b[2J\\x07\\x0d\\x0a\\x09\\x7f");
  EXPECT_EQ(printable("a\0b"sv), "a\\x00b");  // a NUL no longer ends the text
}

TEST(Printable, C1ControlsAndBytesThatAreNotUtf8AreEscaped) {
  EXPECT_EQ(printable("\xc2\x9b" "2J"), "\\xc2\\x9b2J");           // U+009B, CSI
  EXPECT_EQ(printable("\xc2\xa0"), "\xc2\xa0");                     // U+00A0 is text
  EXPECT_EQ(printable("\xff\xfe"), "\\xff\\xfe");                   // never UTF-8
  EXPECT_EQ(printable("\xc3"), "\\xc3");                            // cut short
  EXPECT_EQ(printable("\xc0\xaf"), "\\xc0\\xaf");                   // overlong '/'
  EXPECT_EQ(printable("\xed\xa0\x80"), "\\xed\\xa0\\x80");          // a surrogate
  EXPECT_EQ(printable("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // above U+10FFFF
}

}  // namespace
}  // namespace tether::cli::testing
