// Unit tests of the platform's one JSON string escaping (peis/json_string.h):
// control bytes, quotes and backslashes, valid UTF-8 kept, and every kind of
// invalid UTF-8 replaced so the output stays valid UTF-8.
#include "peis/json_string.h"

#include <catch2/catch.hpp>
#include <string>

using peis::json::isValidUtf8;
using peis::json::quote;
using peis::json::utf8SequenceLength;

namespace {
const std::string kReplacement = "\xEF\xBF\xBD";  // U+FFFD
}

TEST_CASE("json quote escapes quotes, backslashes and every control byte", "[unit]") {
  CHECK(quote("") == "\"\"");
  CHECK(quote("plain text 123") == "\"plain text 123\"");
  CHECK(quote("a\"b") == "\"a\\\"b\"");
  CHECK(quote("a\\b") == "\"a\\\\b\"");
  CHECK(quote("\\\"") == "\"\\\\\\\"\"");
  CHECK(quote("line\nnext\r\ttab") == "\"line\\nnext\\r\\ttab\"");
  CHECK(quote(std::string("nul\0byte", 8)) == "\"nul\\u0000byte\"");
  CHECK(quote("\x01\x08\x0c\x1b\x1f") == "\"\\u0001\\u0008\\u000c\\u001b\\u001f\"");
  CHECK(quote("\x7f") == "\"\\u007f\"");
  CHECK(quote("/ and ' stay") == "\"/ and ' stay\"");
  // Every byte below 0x20 comes out escaped, never raw.
  for (int c = 0; c < 0x20; ++c) {
    const auto out = quote(std::string(1, static_cast<char>(c)));
    INFO("byte " << c);
    CHECK(out.size() >= 4);
    for (std::size_t i = 1; i + 1 < out.size(); ++i)
      CHECK(static_cast<unsigned char>(out[i]) >= 0x20);
  }
}

TEST_CASE("json quote keeps valid UTF-8 as it is", "[unit]") {
  const std::string text =
      "caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80 \xEF\xBF\xBF \xF4\x8F\xBF\xBF";
  CHECK(isValidUtf8(text));
  CHECK(quote(text) == "\"" + text + "\"");
  CHECK(utf8SequenceLength("\xC3\xA9", 0) == 2);
  CHECK(utf8SequenceLength("\xE2\x82\xAC", 0) == 3);
  CHECK(utf8SequenceLength("\xF0\x9F\x98\x80", 0) == 4);
  CHECK(utf8SequenceLength("a", 0) == 1);
  CHECK(utf8SequenceLength("a", 1) == 0);  // past the end
}

TEST_CASE("json quote replaces each byte of invalid UTF-8 by U+FFFD", "[unit]") {
  const auto r = kReplacement;
  struct Case {
    const char* what;
    std::string in, out;
  };
  const Case cases[] = {
      {"a stray continuation byte", "a\x80z", "a" + r + "z"},
      {"0xFF", "\xFF", r},
      {"0xFE", "\xFE", r},
      {"an overlong two-byte form of '/'", "\xC0\xAF", r + r},
      {"C1 (always overlong)", "\xC1\xBF", r + r},
      {"an overlong three-byte form", "\xE0\x80\xAF", r + r + r},
      {"an overlong four-byte form", "\xF0\x80\x80\xAF", r + r + r + r},
      {"a UTF-16 surrogate", "\xED\xA0\x80", r + r + r},
      {"beyond U+10FFFF", "\xF4\x90\x80\x80", r + r + r + r},
      {"F5 starts nothing", "\xF5\x80\x80\x80", r + r + r + r},
      {"a sequence cut short at the end", "ok\xE2\x82", "ok" + r + r},
      {"a sequence cut short by ASCII", "\xE2\x82x", r + r + "x"},
      {"a lead byte then a quote", "\xC3\"", r + "\\\""},
      {"invalid between valid", "\xC3\xA9\xFF\xC3\xA9", "\xC3\xA9" + r + "\xC3\xA9"},
  };
  for (const auto& c : cases) {
    INFO(c.what);
    CHECK(!isValidUtf8(c.in));
    const auto out = quote(c.in);
    CHECK(out == "\"" + c.out + "\"");
    CHECK(isValidUtf8(out));
  }
}

TEST_CASE("json quote output is valid UTF-8 and JSON for every single byte and pair", "[unit]") {
  for (int a = 0; a < 256; ++a) {
    for (int b = 0; b < 256; b += 17) {
      const std::string in{static_cast<char>(a), static_cast<char>(b)};
      const auto out = quote(in);
      INFO("bytes " << a << " " << b);
      REQUIRE(isValidUtf8(out));
      REQUIRE(out.front() == '"');
      REQUIRE(out.back() == '"');
      // No raw control byte and no unescaped quote inside.
      for (std::size_t i = 1; i + 1 < out.size(); ++i) {
        REQUIRE(static_cast<unsigned char>(out[i]) >= 0x20);
        if (out[i] == '"') REQUIRE(out[i - 1] == '\\');
      }
    }
  }
}

TEST_CASE("json appendString appends to what is there", "[unit]") {
  std::string out = "{\"k\":";
  peis::json::appendString(out, "v\n");
  CHECK(out == "{\"k\":\"v\\n\"");
}
