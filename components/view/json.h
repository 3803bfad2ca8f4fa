// JSON for the view's WebSocket protocol (docs/operating.md, "The view's
// protocol"): a writer whose strings are always valid UTF-8 (a browser
// closes a WebSocket whose text frame is not), and a reader of the small
// messages browsers send, bounded in depth, with errors that say where.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "peis/json_string.h"

namespace peis::view::json {

// String literals: the platform's one JSON escaping (peis/json_string.h):
// quotes, escapes, and every byte sequence that is not valid UTF-8 replaced
// by U+FFFD.
using peis::json::appendString;
using peis::json::isValidUtf8;
using peis::json::quote;

// Builds one JSON text; the caller keeps the nesting right, the writer the
// commas.
class Writer {
 public:
  Writer& beginObject();
  Writer& endObject();
  Writer& beginArray();
  Writer& endArray();
  Writer& key(std::string_view name);  // inside an object, before its value
  Writer& string(std::string_view text);
  Writer& number(double value);  // null when not finite
  Writer& integer(std::int64_t value);
  Writer& unsignedInteger(std::uint64_t value);
  Writer& boolean(bool value);
  Writer& null();
  // Inserts `json` (already encoded) as a value.
  Writer& raw(std::string_view json);
  const std::string& text() const { return out_; }
  std::string take() { return std::move(out_); }

 private:
  void beforeValue();
  std::string out_;
  std::vector<bool> first_;  // per open container: nothing written in it yet
  bool afterKey_ = false;
};

// A parsed JSON value.
struct Value;
using Object = std::vector<std::pair<std::string, Value>>;
using Array = std::vector<Value>;
struct Value {
  std::variant<std::nullptr_t, bool, double, std::string, Array, Object> v;

  bool isNull() const { return std::holds_alternative<std::nullptr_t>(v); }
  const std::string* asString() const { return std::get_if<std::string>(&v); }
  const double* asNumber() const { return std::get_if<double>(&v); }
  const bool* asBool() const { return std::get_if<bool>(&v); }
  const Object* asObject() const { return std::get_if<Object>(&v); }
  // The member `name` of an object (the first of that name), or nullptr.
  const Value* member(std::string_view name) const;
  // "a string", "a number", ... for error messages.
  const char* typeName() const;
};

struct ParseError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr int kMaxDepth = 16;

// Parses one JSON text (RFC 8259; surrounding white space allowed). Throws
// ParseError("<problem> at byte N") for anything else, for nesting deeper
// than kMaxDepth, and for strings that are not valid UTF-8.
Value parse(std::string_view text);

}  // namespace peis::view::json
