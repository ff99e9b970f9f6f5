#pragma once
/// @file
/// A small, strict XML element reader and the escaping a writer needs: enough for the files
/// MicMac reads and writes (io/micmac_orientation.hpp), not a general XML library. Standard library
/// only.
///
/// Reads nested elements with their attributes and text; skips comments, the `<?xml ...?>` prolog
/// and other processing instructions; decodes the five predefined entities (&lt; &gt; &amp; &quot;
/// &apos;), character references (&#65; &#x41;) and CDATA sections. Refuses what it does not read
/// rather than guessing: a DOCTYPE (and so any other entity), an unclosed or mismatched tag, a
/// second root, text outside the root. Every error names the document and the line.

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/io/utf8.hpp>

namespace diachron {

/// One element of an XML document. A value type.
struct XmlElement {
  std::string name;  ///< tag name, as written (namespace prefix included, e.g. "a:b")
  /// Attributes in document order, values decoded.
  std::vector<std::pair<std::string, std::string>> attributes;
  /// The element's own character data (entities decoded, CDATA included), the text of its children
  /// excluded; whitespace is kept, so a container holds its indentation.
  std::string text;
  std::vector<XmlElement> children;  ///< child elements in document order
  int line = 0;                      ///< 1-based line of the start tag

  /// The first child named `child_name`, or nullptr.
  const XmlElement* child(std::string_view child_name) const {
    for (const XmlElement& c : children)
      if (c.name == child_name) return &c;
    return nullptr;
  }

  /// Every child named `child_name`, in document order.
  std::vector<const XmlElement*> children_named(std::string_view child_name) const {
    std::vector<const XmlElement*> out;
    for (const XmlElement& c : children)
      if (c.name == child_name) out.push_back(&c);
    return out;
  }

  /// The value of attribute `attribute_name`, or nullptr.
  const std::string* attribute(std::string_view attribute_name) const {
    for (const auto& a : attributes)
      if (a.first == attribute_name) return &a.second;
    return nullptr;
  }
};

/// Parses an XML document and returns its root element. `where` names the document in messages
/// (a path). Throws diachron::Error "<where>:<line>: ..." for text that is not well-formed XML
/// or uses what this reader refuses (see the file comment). Nesting deeper than 256 elements is
/// refused, so hostile input cannot exhaust the stack.
inline XmlElement parse_xml(std::string_view text, const std::string& where);

/// Reads and parses the file at `path` (parse_xml naming the file). Throws diachron::Error naming
/// the path when it cannot be opened.
inline XmlElement read_xml_file(const std::string& path);

/// `text` with & < > " ' replaced by their entities, fit for element text and attribute values.
inline std::string xml_escaped(std::string_view text);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

class XmlLiteParser {
 public:
  XmlLiteParser(std::string_view text, const std::string& where) : text_(text), where_(where) {}

  XmlElement parse_document() {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") i_ = 3;  // UTF-8 byte order mark
    skip_misc();
    if (i_ >= text_.size()) fail("no root element");
    if (text_[i_] != '<') fail("text before the root element");
    XmlElement root = parse_element(0);
    skip_misc();
    if (i_ < text_.size()) fail(text_[i_] == '<' ? "a second root element" : "text after the root element");
    return root;
  }

 private:
  static constexpr int kMaxDepth = 256;

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("diachron: " + where_ + ":" + std::to_string(line_) + ": " + what);
  }

  bool starts_with(std::string_view s) const { return text_.substr(i_, s.size()) == s; }

  // Advances over `n` characters, counting lines.
  void advance(std::size_t n) {
    for (std::size_t k = 0; k < n && i_ < text_.size(); ++k, ++i_)
      if (text_[i_] == '\n') ++line_;
  }

  // Advances to just after `end`, failing with `what` when it never comes.
  void skip_past(std::string_view end, const char* what) {
    const std::size_t at = text_.find(end, i_);
    if (at == std::string_view::npos) fail(what);
    advance(at + end.size() - i_);
  }

  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }
  static bool is_name_start(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == ':' ||
           static_cast<unsigned char>(c) >= 0x80;
  }
  static bool is_name_char(char c) {
    return is_name_start(c) || (c >= '0' && c <= '9') || c == '-' || c == '.';
  }

  void skip_space() {
    while (i_ < text_.size() && is_space(text_[i_])) advance(1);
  }

  // Whitespace, comments and processing instructions (the prolog among them) outside the root.
  void skip_misc() {
    for (;;) {
      skip_space();
      if (starts_with("<!--")) {
        skip_past("-->", "unclosed comment");
      } else if (starts_with("<?")) {
        skip_past("?>", "unclosed processing instruction");
      } else if (starts_with("<!DOCTYPE")) {
        fail("DOCTYPE is not supported");
      } else {
        return;
      }
    }
  }

  std::string parse_name(const char* what) {
    if (i_ >= text_.size() || !is_name_start(text_[i_])) fail(std::string("expected ") + what);
    const std::size_t start = i_;
    while (i_ < text_.size() && is_name_char(text_[i_])) ++i_;
    return std::string(text_.substr(start, i_ - start));
  }

  // Decodes the reference starting at '&' and appends it to `out`.
  void parse_reference(std::string& out) {
    const std::size_t semicolon = text_.find(';', i_);
    if (semicolon == std::string_view::npos || semicolon - i_ > 12) fail("'&' that starts no entity (write &amp;)");
    const std::string_view ref = text_.substr(i_ + 1, semicolon - i_ - 1);
    if (ref == "lt") {
      out += '<';
    } else if (ref == "gt") {
      out += '>';
    } else if (ref == "amp") {
      out += '&';
    } else if (ref == "quot") {
      out += '"';
    } else if (ref == "apos") {
      out += '\'';
    } else if (ref.size() >= 2 && ref[0] == '#') {
      const bool hex = ref[1] == 'x';
      const std::string_view digits = ref.substr(hex ? 2 : 1);
      std::uint32_t cp = 0;
      if (digits.empty()) fail("empty character reference");
      for (const char c : digits) {
        int d = -1;
        if (c >= '0' && c <= '9') d = c - '0';
        else if (hex && c >= 'a' && c <= 'f') d = c - 'a' + 10;
        else if (hex && c >= 'A' && c <= 'F') d = c - 'A' + 10;
        if (d < 0) fail("bad character reference '&" + std::string(ref) + ";'");
        cp = cp * (hex ? 16u : 10u) + static_cast<std::uint32_t>(d);
        if (cp > 0x10FFFF) fail("character reference beyond Unicode '&" + std::string(ref) + ";'");
      }
      if (cp == 0) fail("character reference to NUL");
      append_utf8(out, cp);
    } else {
      fail("unknown entity '&" + std::string(ref) + ";'");
    }
    advance(semicolon + 1 - i_);
  }

  std::string parse_attribute_value() {
    if (i_ >= text_.size() || (text_[i_] != '"' && text_[i_] != '\'')) fail("attribute value must be quoted");
    const char quote = text_[i_];
    advance(1);
    std::string value;
    for (;;) {
      if (i_ >= text_.size()) fail("unclosed attribute value");
      const char c = text_[i_];
      if (c == quote) break;
      if (c == '<') fail("'<' in an attribute value");
      if (c == '&') {
        parse_reference(value);
      } else {
        value += c;
        advance(1);
      }
    }
    advance(1);
    return value;
  }

  XmlElement parse_element(int depth) {
    if (depth >= kMaxDepth) fail("elements nested deeper than " + std::to_string(kMaxDepth));
    XmlElement element;
    element.line = line_;
    advance(1);  // '<'
    element.name = parse_name("an element name after '<'");
    for (;;) {
      const bool spaced = i_ < text_.size() && is_space(text_[i_]);
      skip_space();
      if (i_ >= text_.size()) fail("unclosed start tag <" + element.name + ">");
      if (starts_with("/>")) {
        advance(2);
        return element;
      }
      if (text_[i_] == '>') {
        advance(1);
        break;
      }
      if (!spaced) fail("expected a space, '>' or '/>' in the start tag <" + element.name + ">");
      std::string attribute = parse_name("an attribute name");
      for (const auto& a : element.attributes)
        if (a.first == attribute) fail("attribute '" + attribute + "' repeated in <" + element.name + ">");
      skip_space();
      if (i_ >= text_.size() || text_[i_] != '=') fail("expected '=' after the attribute '" + attribute + "'");
      advance(1);
      skip_space();
      element.attributes.emplace_back(std::move(attribute), parse_attribute_value());
    }
    // Content, up to the matching end tag.
    for (;;) {
      if (i_ >= text_.size())
        fail("element <" + element.name + "> opened on line " + std::to_string(element.line) + " is not closed");
      const char c = text_[i_];
      if (c == '<') {
        if (starts_with("</")) {
          advance(2);
          const std::string end = parse_name("an element name after '</'");
          if (end != element.name)
            fail("</" + end + "> closes <" + element.name + "> opened on line " + std::to_string(element.line));
          skip_space();
          if (i_ >= text_.size() || text_[i_] != '>') fail("expected '>' to end </" + end + ">");
          advance(1);
          return element;
        }
        if (starts_with("<!--")) {
          skip_past("-->", "unclosed comment");
        } else if (starts_with("<![CDATA[")) {
          advance(9);
          const std::size_t at = text_.find("]]>", i_);
          if (at == std::string_view::npos) fail("unclosed CDATA section");
          element.text.append(text_.substr(i_, at - i_));
          advance(at + 3 - i_);
        } else if (starts_with("<?")) {
          skip_past("?>", "unclosed processing instruction");
        } else if (starts_with("<!")) {
          fail("unsupported markup '<!' in <" + element.name + ">");
        } else {
          element.children.push_back(parse_element(depth + 1));
        }
      } else if (c == '&') {
        parse_reference(element.text);
      } else {
        element.text += c;
        advance(1);
      }
    }
  }

  std::string_view text_;
  const std::string& where_;
  std::size_t i_ = 0;
  int line_ = 1;
};

}  // namespace detail

inline XmlElement parse_xml(std::string_view text, const std::string& where) {
  return detail::XmlLiteParser(text, where).parse_document();
}

inline XmlElement read_xml_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "': the file does not exist or cannot be opened");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_xml(text, path);
}

inline std::string xml_escaped(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace diachron
