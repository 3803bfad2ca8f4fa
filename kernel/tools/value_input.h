// Where a VALUE argument comes from: as written, "-" for stdin, "@FILE" for
// a file's bytes. Data that is not text (a NUL or control byte, or invalid
// UTF-8) is marked binary.
#pragma once

#include <istream>
#include <string>
#include <string_view>

namespace peis::cli {

struct Value {
  std::string data;
  bool binary = false;
};

// The value `arg` stands for. With `literal`, `arg` itself. Text read from
// stdin or a file loses one trailing newline ("echo on | peis set 7.light -"
// sets "on"); binary data is kept byte for byte. Throws UsageError when the
// file cannot be read.
Value readValue(const std::string& arg, bool literal, std::istream& in);

// True for bytes that are not text: NUL, a control byte other than tab,
// newline and carriage return, or invalid UTF-8.
bool looksBinary(std::string_view data);

}  // namespace peis::cli
