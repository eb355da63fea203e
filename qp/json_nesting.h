#pragma once

// A guard for the JSON problem files the ID records and hyq-qp-solve exchange: how deep arrays and
// objects nest, counted before a parser sees the text. nlohmann's dump() and destructor recurse once
// per level, so 100 000 '[' overflow the stack; the readers refuse a text deeper than their limit.

#include <algorithm>
#include <string_view>

namespace hyq::qp {

// The deepest nesting of arrays and objects in `text` (outside strings), counted up to `limit` + 1.
inline int JsonNestingDepth(std::string_view text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) break;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

}  // namespace hyq::qp
