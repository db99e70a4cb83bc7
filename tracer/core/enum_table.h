// One table per enum: value ↔ file/CLI name ↔ UI label. JSON, the command line, the viewer and the docs all read
// these tables (yocto-gl keeps one label table per enum the same way), so a name is spelled in one place only.
#pragma once
#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace pt {

template <class E>
struct EnumEntry {
  E value;
  const char* name;   // as written in scene files and on the command line
  const char* label;  // as shown in the viewer
};

// Specialise for each enum: `template <> struct EnumTable<E> { static constexpr std::array<EnumEntry<E>, N> kEntries{...}; };`
template <class E>
struct EnumTable;

template <class E>
constexpr std::span<const EnumEntry<E>> enum_entries() {
  return {EnumTable<E>::kEntries.data(), EnumTable<E>::kEntries.size()};
}

template <class E>
constexpr const char* enum_name(E value) {
  for (const auto& e : enum_entries<E>())
    if (e.value == value) return e.name;
  return "?";
}

template <class E>
constexpr const char* enum_label(E value) {
  for (const auto& e : enum_entries<E>())
    if (e.value == value) return e.label;
  return "?";
}

template <class E>
bool parse_enum(std::string_view name, E& out) {
  for (const auto& e : enum_entries<E>())
    if (name == e.name) {
      out = e.value;
      return true;
    }
  return false;
}

// "a, b, c": the accepted names, for error messages and --help.
template <class E>
std::string enum_names_joined(const char* separator = ", ") {
  std::string out;
  for (const auto& e : enum_entries<E>()) out += (out.empty() ? "" : separator) + std::string(e.name);
  return out;
}

// The accepted names as a list (for CLI11's IsMember check).
template <class E>
std::vector<std::string> enum_name_list() {
  std::vector<std::string> out;
  for (const auto& e : enum_entries<E>()) out.emplace_back(e.name);
  return out;
}

template <class E>
constexpr size_t enum_index(E value) {
  const auto entries = enum_entries<E>();
  for (size_t i = 0; i < entries.size(); ++i)
    if (entries[i].value == value) return i;
  return 0;
}

}  // namespace pt
