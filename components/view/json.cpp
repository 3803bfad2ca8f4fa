// JSON writer and reader of the view's protocol (json.h).
#include "view/json.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace peis::view::json {
namespace {

void appendUtf8(std::string& out, std::uint32_t code) {
  if (code < 0x80) {
    out += static_cast<char>(code);
  } else if (code < 0x800) {
    out += static_cast<char>(0xC0 | (code >> 6));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else if (code < 0x10000) {
    out += static_cast<char>(0xE0 | (code >> 12));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (code >> 18));
    out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  }
}

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  Value document() {
    skipSpace();
    Value value = parseValue(0);
    skipSpace();
    if (at_ != text_.size()) fail("unexpected text after the value");
    return value;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw ParseError(problem + " at byte " + std::to_string(at_));
  }
  bool atEnd() const { return at_ >= text_.size(); }
  char peek() const { return atEnd() ? '\0' : text_[at_]; }
  void skipSpace() {
    while (!atEnd() && (peek() == ' ' || peek() == '\t' || peek() == '\n' || peek() == '\r')) ++at_;
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++at_;
  }
  void literal(std::string_view word) {
    if (text_.substr(at_, word.size()) != word) fail("unexpected character");
    at_ += word.size();
  }

  Value parseValue(int depth) {
    if (depth >= kMaxDepth) fail("nested deeper than " + std::to_string(kMaxDepth) + " levels");
    if (atEnd()) fail("unexpected end");
    switch (peek()) {
      case '{':
        return Value{parseObject(depth)};
      case '[':
        return Value{parseArray(depth)};
      case '"':
        return Value{parseString()};
      case 't':
        literal("true");
        return Value{true};
      case 'f':
        literal("false");
        return Value{false};
      case 'n':
        literal("null");
        return Value{nullptr};
      default:
        if (peek() == '-' || (peek() >= '0' && peek() <= '9')) return Value{parseNumber()};
        fail("unexpected character");
    }
  }

  Object parseObject(int depth) {
    expect('{');
    Object object;
    skipSpace();
    if (peek() == '}') {
      ++at_;
      return object;
    }
    for (;;) {
      skipSpace();
      if (peek() != '"') fail("expected a member name");
      std::string name = parseString();
      skipSpace();
      expect(':');
      skipSpace();
      object.emplace_back(std::move(name), parseValue(depth + 1));
      skipSpace();
      if (peek() == ',') {
        ++at_;
        continue;
      }
      expect('}');
      return object;
    }
  }

  Array parseArray(int depth) {
    expect('[');
    Array array;
    skipSpace();
    if (peek() == ']') {
      ++at_;
      return array;
    }
    for (;;) {
      skipSpace();
      array.push_back(parseValue(depth + 1));
      skipSpace();
      if (peek() == ',') {
        ++at_;
        continue;
      }
      expect(']');
      return array;
    }
  }

  std::uint32_t hex4() {
    if (at_ + 4 > text_.size()) fail("unexpected end in a \\u escape");
    std::uint32_t code = 0;
    for (int k = 0; k < 4; ++k) {
      const char c = text_[at_++];
      code <<= 4;
      if (c >= '0' && c <= '9')
        code |= c - '0';
      else if (c >= 'a' && c <= 'f')
        code |= c - 'a' + 10;
      else if (c >= 'A' && c <= 'F')
        code |= c - 'A' + 10;
      else
        fail("bad \\u escape");
    }
    return code;
  }

  std::string parseString() {
    expect('"');
    std::string out;
    for (;;) {
      if (atEnd()) fail("unterminated string");
      const unsigned char c = static_cast<unsigned char>(text_[at_]);
      if (c == '"') {
        ++at_;
        return out;
      }
      if (c < 0x20) fail("control character in a string");
      if (c == '\\') {
        ++at_;
        if (atEnd()) fail("unterminated string");
        const char e = text_[at_++];
        switch (e) {
          case '"':
          case '\\':
          case '/':
            out += e;
            break;
          case 'b':
            out += '\b';
            break;
          case 'f':
            out += '\f';
            break;
          case 'n':
            out += '\n';
            break;
          case 'r':
            out += '\r';
            break;
          case 't':
            out += '\t';
            break;
          case 'u': {
            std::uint32_t code = hex4();
            if (code >= 0xD800 && code <= 0xDBFF) {
              if (text_.substr(at_, 2) != "\\u") fail("lone surrogate in a \\u escape");
              at_ += 2;
              const std::uint32_t low = hex4();
              if (low < 0xDC00 || low > 0xDFFF) fail("lone surrogate in a \\u escape");
              code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
            } else if (code >= 0xDC00 && code <= 0xDFFF) {
              fail("lone surrogate in a \\u escape");
            }
            appendUtf8(out, code);
            break;
          }
          default:
            fail("bad escape");
        }
        continue;
      }
      const std::size_t length = peis::json::utf8SequenceLength(text_, at_);
      if (length == 0) fail("invalid UTF-8 in a string");
      out.append(text_.substr(at_, length));
      at_ += length;
    }
  }

  double parseNumber() {
    const std::size_t start = at_;
    if (peek() == '-') ++at_;
    if (peek() == '0') {
      ++at_;
    } else if (peek() >= '1' && peek() <= '9') {
      while (peek() >= '0' && peek() <= '9') ++at_;
    } else {
      fail("bad number");
    }
    if (peek() == '.') {
      ++at_;
      if (!(peek() >= '0' && peek() <= '9')) fail("bad number");
      while (peek() >= '0' && peek() <= '9') ++at_;
    }
    if (peek() == 'e' || peek() == 'E') {
      ++at_;
      if (peek() == '+' || peek() == '-') ++at_;
      if (!(peek() >= '0' && peek() <= '9')) fail("bad number");
      while (peek() >= '0' && peek() <= '9') ++at_;
    }
    const std::string number(text_.substr(start, at_ - start));
    const double value = std::strtod(number.c_str(), nullptr);
    if (!std::isfinite(value)) fail("number out of range");
    return value;
  }

  std::string_view text_;
  std::size_t at_ = 0;
};

}  // namespace

void Writer::beforeValue() {
  if (afterKey_) {
    afterKey_ = false;
    return;
  }
  if (!first_.empty()) {
    if (!first_.back()) out_ += ',';
    first_.back() = false;
  }
}

Writer& Writer::beginObject() {
  beforeValue();
  out_ += '{';
  first_.push_back(true);
  return *this;
}

Writer& Writer::endObject() {
  out_ += '}';
  first_.pop_back();
  return *this;
}

Writer& Writer::beginArray() {
  beforeValue();
  out_ += '[';
  first_.push_back(true);
  return *this;
}

Writer& Writer::endArray() {
  out_ += ']';
  first_.pop_back();
  return *this;
}

Writer& Writer::key(std::string_view name) {
  beforeValue();
  appendString(out_, name);
  out_ += ':';
  afterKey_ = true;
  return *this;
}

Writer& Writer::string(std::string_view text) {
  beforeValue();
  appendString(out_, text);
  return *this;
}

Writer& Writer::number(double value) {
  beforeValue();
  if (!std::isfinite(value)) {
    out_ += "null";
    return *this;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", value);
  out_ += buf;
  return *this;
}

Writer& Writer::integer(std::int64_t value) {
  beforeValue();
  out_ += std::to_string(value);
  return *this;
}

Writer& Writer::unsignedInteger(std::uint64_t value) {
  beforeValue();
  out_ += std::to_string(value);
  return *this;
}

Writer& Writer::boolean(bool value) {
  beforeValue();
  out_ += value ? "true" : "false";
  return *this;
}

Writer& Writer::null() {
  beforeValue();
  out_ += "null";
  return *this;
}

Writer& Writer::raw(std::string_view json) {
  beforeValue();
  out_ += json;
  return *this;
}

const Value* Value::member(std::string_view name) const {
  const auto* object = asObject();
  if (!object) return nullptr;
  for (const auto& [key, value] : *object) {
    if (key == name) return &value;
  }
  return nullptr;
}

const char* Value::typeName() const {
  switch (v.index()) {
    case 0:
      return "null";
    case 1:
      return "a boolean";
    case 2:
      return "a number";
    case 3:
      return "a string";
    case 4:
      return "an array";
    default:
      return "an object";
  }
}

Value parse(std::string_view text) { return Parser(text).document(); }

}  // namespace peis::view::json
