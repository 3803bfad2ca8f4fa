// VALUE arguments from stdin or a file (kernel/tools/value_input.h).
#include "value_input.h"

#include <catch2/catch.hpp>
#include <sstream>

#include "args.h"
#include "support/temp_dir.h"

using peis::cli::looksBinary;
using peis::cli::readValue;

TEST_CASE("a value as written, from stdin or from a file", "[unit][cli]") {
  peis::test::TempDir dir("peis-value");
  std::istringstream none;
  CHECK(readValue("on", false, none).data == "on");
  CHECK_FALSE(readValue("on", false, none).binary);

  std::istringstream in("on\n");
  CHECK(readValue("-", false, in).data == "on");  // one trailing newline goes

  const auto text = dir.write("text.txt", "line one\nline two\n\n");
  CHECK(readValue("@" + text, false, none).data == "line one\nline two\n");

  const std::string bytes("\x89PNG\r\n\x1a\n\0\0\0\n", 12);
  const auto binary = dir.write("image.png", bytes);
  const auto value = readValue("@" + binary, false, none);
  CHECK(value.binary);
  CHECK(value.data == bytes);  // byte for byte, the trailing newline kept

  std::istringstream untouched("x");
  CHECK(readValue("-", true, untouched).data == "-");  // --literal
  CHECK(readValue("@" + text, true, none).data == "@" + text);
}

TEST_CASE("a file that cannot be read is a usage error naming it", "[unit][cli]") {
  std::istringstream none;
  CHECK_THROWS_WITH(readValue("@/nonexistent/value", false, none),
                    Catch::Contains("cannot read /nonexistent/value"));
  CHECK_THROWS_AS(readValue("@", false, none), peis::cli::UsageError);
}

TEST_CASE("binary or text", "[unit][cli]") {
  CHECK_FALSE(looksBinary(""));
  CHECK_FALSE(looksBinary("plain text\twith tabs\r\n"));
  CHECK_FALSE(looksBinary("Grüße, 温度 21.5 °C"));
  CHECK(looksBinary(std::string("a\0b", 3)));
  CHECK(looksBinary("\x01\x02"));
  CHECK(looksBinary("\xff\xfe"));  // not UTF-8
  CHECK(looksBinary("caf\xc3"));   // a sequence cut short
  CHECK(looksBinary("\xc3\x28"));  // a bad continuation byte
}
