#pragma once
/// @file
/// A small JSON reader (RFC 8259: objects, arrays, numbers, strings, true, false, null) and the
/// two helpers writers need (quoted strings, round-trip doubles), for the library's own JSON files
/// (cameras.json). Standard library only; not a general-purpose JSON library: no streaming, no
/// comments, duplicate keys rejected.

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <locale>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/io/utf8.hpp>

namespace diachron {

/// A parsed JSON value. Objects keep their keys in file order.
struct JsonValue {
  enum class Type { null, boolean, number, string, array, object };

  Type type = Type::null;
  bool boolean = false;
  double number = 0.0;  ///< may be +-infinity when the text overflows a double; callers check
  std::string string;
  std::vector<JsonValue> array;
  std::vector<std::pair<std::string, JsonValue>> object;

  /// The member `key` of an object, or nullptr (also for a value that is not an object).
  const JsonValue* find(std::string_view key) const {
    if (type != Type::object) return nullptr;
    for (const auto& [k, v] : object)
      if (k == key) return &v;
    return nullptr;
  }
};

/// The name of a JSON type, for messages ("number", "object", ...).
inline const char* json_type_name(JsonValue::Type t) {
  switch (t) {
    case JsonValue::Type::null: return "null";
    case JsonValue::Type::boolean: return "boolean";
    case JsonValue::Type::number: return "number";
    case JsonValue::Type::string: return "string";
    case JsonValue::Type::array: return "array";
    case JsonValue::Type::object: return "object";
  }
  return "?";
}

/// Parses `text` (one JSON value, white space around it allowed). Throws diachron::Error
/// "<where>: line L, column C: <what>" for anything that is not JSON, nesting deeper than 200, or
/// a key that appears twice in one object.
inline JsonValue parse_json(std::string_view text, const std::string& where);

/// `s` as a JSON string literal (quotes, backslash and control characters escaped; UTF-8 passed through).
inline std::string json_quoted(std::string_view s);

/// `v` as JSON text that reads back to the same double (max_digits10 significant digits, C locale).
/// Precondition: finite (JSON has no NaN or infinity), else throws diachron::Error.
inline std::string json_number(double v);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

class JsonParser {
 public:
  JsonParser(std::string_view text, const std::string& where) : text_(text), where_(where) {}

  JsonValue parse_document() {
    skip_space();
    JsonValue v = parse_value(0);
    skip_space();
    if (i_ != text_.size()) fail("unexpected text after the JSON value");
    return v;
  }

 private:
  static constexpr int kMaxDepth = 200;

  [[noreturn]] void fail(const std::string& what) const {
    std::size_t line = 1, column = 1;
    for (std::size_t k = 0; k < i_ && k < text_.size(); ++k) {
      if (text_[k] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::ostringstream out;
    out << "diachron: " << where_ << ": line " << line << ", column " << column << ": " << what;
    throw Error(out.str());
  }

  void skip_space() {
    while (i_ < text_.size() && (text_[i_] == ' ' || text_[i_] == '\t' || text_[i_] == '\n' || text_[i_] == '\r')) ++i_;
  }

  bool literal(std::string_view word) {
    if (text_.substr(i_, word.size()) != word) return false;
    i_ += word.size();
    return true;
  }

  JsonValue parse_value(int depth) {
    if (depth > kMaxDepth) fail("nesting deeper than " + std::to_string(kMaxDepth));
    if (i_ >= text_.size()) fail("unexpected end of the text, a value was expected");
    JsonValue v;
    const char c = text_[i_];
    if (c == '{') {
      parse_object(v, depth);
    } else if (c == '[') {
      parse_array(v, depth);
    } else if (c == '"') {
      v.type = JsonValue::Type::string;
      v.string = parse_string();
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      v.type = JsonValue::Type::number;
      v.number = parse_number();
    } else if (literal("true")) {
      v.type = JsonValue::Type::boolean;
      v.boolean = true;
    } else if (literal("false")) {
      v.type = JsonValue::Type::boolean;
    } else if (!literal("null")) {
      fail(std::string("unexpected character '") + c + "', a value was expected");
    }
    return v;
  }

  void parse_object(JsonValue& v, int depth) {
    v.type = JsonValue::Type::object;
    ++i_;
    skip_space();
    if (i_ < text_.size() && text_[i_] == '}') {
      ++i_;
      return;
    }
    while (true) {
      skip_space();
      if (i_ >= text_.size() || text_[i_] != '"') fail("a quoted key was expected");
      std::string key = parse_string();
      if (v.find(key)) fail("key \"" + key + "\" appears twice");
      skip_space();
      if (i_ >= text_.size() || text_[i_] != ':') fail("':' was expected after key \"" + key + "\"");
      ++i_;
      skip_space();
      JsonValue member = parse_value(depth + 1);
      v.object.emplace_back(std::move(key), std::move(member));
      skip_space();
      if (i_ < text_.size() && text_[i_] == ',') {
        ++i_;
        continue;
      }
      if (i_ < text_.size() && text_[i_] == '}') {
        ++i_;
        return;
      }
      fail("',' or '}' was expected in an object");
    }
  }

  void parse_array(JsonValue& v, int depth) {
    v.type = JsonValue::Type::array;
    ++i_;
    skip_space();
    if (i_ < text_.size() && text_[i_] == ']') {
      ++i_;
      return;
    }
    while (true) {
      skip_space();
      v.array.push_back(parse_value(depth + 1));
      skip_space();
      if (i_ < text_.size() && text_[i_] == ',') {
        ++i_;
        continue;
      }
      if (i_ < text_.size() && text_[i_] == ']') {
        ++i_;
        return;
      }
      fail("',' or ']' was expected in an array");
    }
  }

  std::uint32_t parse_hex4() {
    if (i_ + 4 > text_.size()) fail("\\u needs four hex digits");
    std::uint32_t cp = 0;
    const auto [end, error] = std::from_chars(text_.data() + i_, text_.data() + i_ + 4, cp, 16);
    if (error != std::errc() || end != text_.data() + i_ + 4) fail("\\u needs four hex digits");
    i_ += 4;
    return cp;
  }

  std::string parse_string() {
    ++i_;  // the opening quote
    std::string out;
    while (true) {
      if (i_ >= text_.size()) fail("unterminated string");
      const char c = text_[i_++];
      if (c == '"') return out;
      if (static_cast<unsigned char>(c) < 0x20) {
        --i_;
        fail("control character in a string");
      }
      if (c != '\\') {
        out += c;
        continue;
      }
      if (i_ >= text_.size()) fail("unterminated escape");
      const char e = text_[i_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          std::uint32_t cp = parse_hex4();
          // A surrogate pair encodes one code point above U+FFFF.
          if (cp >= 0xD800 && cp < 0xDC00 && text_.substr(i_, 2) == "\\u") {
            i_ += 2;
            const std::uint32_t low = parse_hex4();
            if (low < 0xDC00 || low >= 0xE000) fail("invalid UTF-16 surrogate pair");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
          }
          append_utf8(out, cp);
          break;
        }
        default: --i_; fail(std::string("invalid escape '\\") + e + "'");
      }
    }
  }

  double parse_number() {
    // JSON's grammar: -? (0 | [1-9][0-9]*) (. [0-9]+)? ([eE] [+-]? [0-9]+)?
    const std::size_t start = i_;
    const auto digits = [this]() {
      const std::size_t from = i_;
      while (i_ < text_.size() && text_[i_] >= '0' && text_[i_] <= '9') ++i_;
      return i_ - from;
    };
    if (text_[i_] == '-') ++i_;
    if (i_ < text_.size() && text_[i_] == '0') {
      ++i_;
    } else if (digits() == 0) {
      fail("invalid number");
    }
    if (i_ < text_.size() && text_[i_] == '.') {
      ++i_;
      if (digits() == 0) fail("invalid number: digits expected after '.'");
    }
    if (i_ < text_.size() && (text_[i_] == 'e' || text_[i_] == 'E')) {
      ++i_;
      if (i_ < text_.size() && (text_[i_] == '+' || text_[i_] == '-')) ++i_;
      if (digits() == 0) fail("invalid number: digits expected in the exponent");
    }
    double value = 0.0;
    const auto [end, error] = std::from_chars(text_.data() + start, text_.data() + i_, value);
    if (error == std::errc::result_out_of_range) {
      // Overflow: keep the sign as an infinity so that the caller's finiteness check names the key;
      // underflow to zero is harmless.
      bool tiny = false;
      for (std::size_t k = start; k < i_; ++k)
        if (text_[k] == 'e' || text_[k] == 'E') tiny = text_[k + 1] == '-';
      return tiny ? 0.0 : (text_[start] == '-' ? -std::numeric_limits<double>::infinity()
                                               : std::numeric_limits<double>::infinity());
    }
    if (error != std::errc() || end != text_.data() + i_) fail("invalid number");
    return value;
  }

  std::string_view text_;
  const std::string& where_;
  std::size_t i_ = 0;
};

}  // namespace detail

inline JsonValue parse_json(std::string_view text, const std::string& where) {
  return detail::JsonParser(text, where).parse_document();
}

inline std::string json_quoted(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static constexpr char kHex[] = "0123456789abcdef";
          out += "\\u00";
          out += kHex[(c >> 4) & 0xF];
          out += kHex[c & 0xF];
        } else {
          out += c;
        }
    }
  }
  out += '"';
  return out;
}

inline std::string json_number(double v) {
  DIACHRON_CHECK(std::isfinite(v), "json_number: JSON cannot hold the non-finite value " << v);
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out.precision(std::numeric_limits<double>::max_digits10);
  out << v;
  return out.str();
}

}  // namespace diachron
