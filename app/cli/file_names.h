// Names made from what a user typed, for files and for shell commands: the reference cache and the plots of
// `bench`, the counted renders of `bench --instructions` (a scene may be a file path, with slashes, spaces and
// quotes in it).
#pragma once
#include <cctype>
#include <string>

namespace pt {

// s with every character other than letters, digits, '.', '_' and '-' made '_': usable as one part of a file
// name (no separator, space or quote left in it).
inline std::string file_name_part(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') c = '_';
  return s;
}

// One argument for /bin/sh, quoted so that no character is special.
inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace pt
