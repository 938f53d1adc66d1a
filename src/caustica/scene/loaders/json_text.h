// Parsing JSON text for the loaders that read JSON (caustica JSON, glTF): every
// failure of the JSON library becomes one InputError line, "<source>:<line>:
// invalid JSON: <what>", never the library's own exception.
#pragma once
#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "../../base/error.h"

namespace caustica {

// Json: nlohmann::json or nlohmann::ordered_json (keeps the file's key order).
template <class Json>
Json parse_json_text(const std::string& text, const std::string& source) {
  using json = Json;
  try {
    return json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    size_t line = 1, byte = std::min<size_t>(e.byte, text.size());
    for (size_t i = 0; i + 1 < byte; ++i) line += text[i] == '\n';
    std::string msg = e.what();
    auto p = msg.find("syntax error");
    throw InputError(source + ":" + std::to_string(line) + ": invalid JSON: " +
                     (p == std::string::npos ? msg : msg.substr(p)));
  } catch (const nlohmann::json::exception& e) {
    // e.g. out_of_range 406, a number too large for a double: no position is
    // given, so the line is that of the first occurrence of the quoted literal.
    std::string msg = e.what();
    auto q0 = msg.find('\''), q1 = msg.rfind('\'');
    size_t line = 0;
    if (q0 != std::string::npos && q1 > q0) {
      size_t at = text.find(msg.substr(q0 + 1, q1 - q0 - 1));
      if (at != std::string::npos) line = 1 + size_t(std::count(text.begin(), text.begin() + long(at), '\n'));
    }
    auto b = msg.find("] ");
    throw InputError(source + (line ? ":" + std::to_string(line) : std::string()) + ": invalid JSON: " +
                     (b == std::string::npos ? msg : msg.substr(b + 2)));
  }
}

}  // namespace caustica
