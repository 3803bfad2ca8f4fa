// VALUE arguments from the command line, stdin or a file; see value_input.h.
#include "value_input.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "args.h"

namespace peis::cli {
namespace {

// Length of the UTF-8 sequence that starts with `lead`, or 0 if invalid.
std::size_t sequenceLength(unsigned char lead) {
  if (lead < 0x80) return 1;
  if (lead >= 0xc2 && lead <= 0xdf) return 2;
  if (lead >= 0xe0 && lead <= 0xef) return 3;
  if (lead >= 0xf0 && lead <= 0xf4) return 4;
  return 0;
}

std::string readAll(std::istream& in) {
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

}  // namespace

bool looksBinary(std::string_view data) {
  for (std::size_t i = 0; i < data.size();) {
    const auto c = static_cast<unsigned char>(data[i]);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') return true;
    if (c == 0x7f) return true;
    const auto length = sequenceLength(c);
    if (length == 0 || i + length > data.size()) return true;
    for (std::size_t k = 1; k < length; ++k) {
      if ((static_cast<unsigned char>(data[i + k]) & 0xc0) != 0x80) return true;
    }
    i += length;
  }
  return false;
}

Value readValue(const std::string& arg, bool literal, std::istream& in) {
  if (literal || (arg != "-" && arg.rfind('@', 0) != 0)) return Value{arg, false};
  std::string data;
  if (arg == "-") {
    data = readAll(in);
    if (in.bad()) throw UsageError("cannot read the value from stdin");
  } else {
    const auto path = arg.substr(1);
    if (path.empty()) throw UsageError("'@' needs a file name (@FILE), or use --literal");
    std::ifstream file(path, std::ios::binary);
    if (!file) throw UsageError("cannot read " + path + ": " + std::strerror(errno));
    data = readAll(file);
    if (file.bad()) throw UsageError("cannot read " + path);
  }
  Value value{std::move(data), false};
  value.binary = looksBinary(value.data);
  if (!value.binary && !value.data.empty() && value.data.back() == '\n') {
    value.data.pop_back();
    if (!value.data.empty() && value.data.back() == '\r') value.data.pop_back();
  }
  return value;
}

}  // namespace peis::cli
