#include "scene/scene_json.h"

#include <nlohmann/json.hpp>
// (Not RAPIDJSON_SSE42: its whitespace skip loads aligned 16-byte blocks that reach past the end of the text,
// which AddressSanitizer rightly reports; it was under 1 % of the loading time.)
#include <rapidjson/error/en.h>
#include <rapidjson/memorystream.h>
#include <rapidjson/reader.h>

#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <string_view>
#include <initializer_list>
#include <algorithm>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "scene/gltf_import.h"
#include "scene/mesh_obj.h"
#include "scene/studio.h"
#include "scene/scene.h"
#include "io/image_io.h"
#include "io/texture_io.h"
#include "io/safe_file.h"

namespace pt {
namespace {

// ordered_json keeps the materials in file order (their order is their index).
using Json = nlohmann::ordered_json;

// A structural problem found while reading the JSON tree; parse_scene() prefixes the source name.
struct PathError {
  std::string path;  // "" for the document itself
  std::string reason;
};

[[noreturn]] void fail(const std::string& path, const std::string& reason) { throw PathError{path, reason}; }

// Text from the file as it appears in a message: control characters escaped (nothing reaches the terminal raw)
// and cut to 80 bytes.
std::string shown(const std::string& s) {
  constexpr size_t kShown = 80;
  std::string out;
  for (size_t i = 0; i < s.size() && i < kShown; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > kShown) out += "... (" + std::to_string(s.size()) + " bytes)";
  return out;
}
std::string shown_quoted(const std::string& s) { return "\"" + shown(s) + "\""; }

std::string member(const std::string& path, const std::string& key) {
  return path.empty() ? shown(key) : path + "." + shown(key);
}
std::string element(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }
std::string quoted(const std::string& s) { return Json(s).dump(-1, ' ', false, Json::error_handler_t::replace); }
std::string got(const Json& v) { return std::string("got ") + v.type_name(); }

std::string join_names(std::initializer_list<const char*> names) {
  std::string out;
  for (const char* n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// Syntax level: RapidJSON's iterative reader (no recursion: nesting cannot overflow the stack; numbers as text,
// converted here with std::from_chars, which is exact) driving a handler that builds the nlohmann tree the typed
// readers below walk, with duplicate-key detection, the JSON path of the value being read, and limits on nesting
// and string length (docs/reliability.md). Building the tree ourselves keeps loading linear: nlohmann's
// callback parser rescans a container's elements after each one, and ordered_json's keyed insert is a linear
// search; keys are checked unique here, so members are appended. The elements of the top-level "shapes" array
// -- nearly all of a large scene -- never stay in the tree: each is handed on as soon as it is complete (see
// SceneSax::end), so 10^6 shapes load in under 2 s (docs/reliability.md).

// RapidJSON reports a syntax error as a code and a byte offset; the message says where (1-based line and
// column of the byte it stopped at) and what.
std::string syntax_message(rapidjson::ParseErrorCode code, size_t offset, const std::string& text) {
  size_t line = 1, column = 1;
  for (size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  std::string reason;
  if (offset >= text.size() && code != rapidjson::kParseErrorDocumentRootNotSingular) {
    reason = "unexpected end of input";
  } else if (code == rapidjson::kParseErrorStringInvalidEncoding) {
    reason = "invalid UTF-8 in a string";
  } else {
    reason = rapidjson::GetParseError_En(code);  // e.g. "Missing a comma or '}' after an object member."
    if (!reason.empty()) reason[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(reason[0])));
    if (!reason.empty() && reason.back() == '.') reason.pop_back();
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column) + ": syntax error: " + reason;
}

class SceneSax : public rapidjson::BaseReaderHandler<rapidjson::UTF8<>, SceneSax> {
 public:
  // Receive the elements of the top-level "shapes" array, in order, once each is complete: a shape in the plain
  // form (an object with the keys of its type, numbers finite) as read by the fast path below, anything else
  // as its JSON tree, for the typed reader (read_shape) to read or to refuse with the reason.
  using ParsedShapeSink = std::function<void(const ShapeDesc& shape, std::string_view material, size_t index)>;
  using ShapeTreeSink = std::function<void(const Json& element, size_t index)>;

  SceneSax(Json& root, ParsedShapeSink parsed_sink, ShapeTreeSink tree_sink)
      : root_(root), parsed_sink_(std::move(parsed_sink)), tree_sink_(std::move(tree_sink)) {}

  // Handler interface (each returns false after storing the problem in error(), which stops the reader).
  bool Null() { return guarded([&] { scalar(Json(nullptr)); }); }
  bool Bool(bool b) { return guarded([&] { scalar(Json(b)); }); }
  bool RawNumber(const char* text, rapidjson::SizeType length, bool) {
    return guarded([&] { scalar(number(std::string_view(text, length))); });
  }
  bool String(const char* text, rapidjson::SizeType length, bool) {
    return guarded([&] {
      check_length(length, "string");
      if (recording_) {
        record(Event::String, std::string_view(text, length));
        element_done();
      } else {
        add(Json(std::string(text, length)));
      }
    });
  }
  bool StartObject() { return guarded([&] { start(false); }); }
  bool Key(const char* text, rapidjson::SizeType length, bool) {
    return guarded([&] {
      check_length(length, "key");
      if (recording_) record(Event::Key, std::string_view(text, length));
      key(std::string_view(text, length));
    });
  }
  bool EndObject(rapidjson::SizeType) { return guarded([&] { end(); }); }
  bool StartArray() { return guarded([&] { start(true); }); }
  bool EndArray(rapidjson::SizeType) { return guarded([&] { end(); }); }

  const std::optional<PathError>& error() const { return error_; }

  // Path of the value currently being read.
  std::string path() const {
    std::string p;
    for (const Frame& f : frames_) p = f.array ? element(p, f.index) : member(p, f.key);
    return p;
  }

 private:
  struct Frame {
    Json* value;  // null while recording a shape
    bool array;
    bool shapes = false;  // the top-level "shapes" array
    size_t index = 0;
    std::string key;
    std::unordered_set<std::string> keys;  // of a large object (small ones compare their members directly)

    // Whether `key` is new in this object. Objects are small (a shape has 3 keys) except the material table.
    bool unique_key() {
      constexpr size_t kLinear = 16;
      const auto& members = value->get_ref<const Json::object_t&>();
      if (members.size() < kLinear) {
        for (const auto& m : members)
          if (m.first == key) return false;
        return true;
      }
      if (keys.empty())
        for (const auto& m : members) keys.insert(m.first);
      return keys.insert(key).second;
    }
  };

  // A shape object is recorded as a flat list of events (no allocation once the buffers have grown), read by
  // read_plain_shape, and replayed into a JSON tree only when it is not in the plain form: building and freeing
  // nlohmann trees for 10^6 shapes took 2 of the 3 seconds of loading them.
  struct Event {
    enum Kind : uint8_t { Null, Bool, Number, String, Key, StartObject, EndObject, StartArray, EndArray } kind;
    bool boolean = false;
    Json number;         // for Number: an integer or a double, as number() read it
    size_t text = 0, length = 0;  // for String and Key: a slice of text_
  };

  template <class F>
  bool guarded(F&& f) {
    try {
      f();
      return true;
    } catch (PathError& e) {
      error_ = std::move(e);
      return false;
    }
  }

  void check_length(size_t length, const char* what) const {
    if (length > kMaxSceneStringBytes)
      fail(path(), std::string(what) + " of " + std::to_string(length) + " bytes (the limit is " +
                       std::to_string(kMaxSceneStringBytes) + ")");
  }

  // A JSON number's text (RapidJSON has checked its grammar): integers stay integers (signed when negative, as
  // nlohmann reads them) unless they overflow 64 bits; the rest are doubles, exactly rounded.
  Json number(std::string_view t) const {
    const char* b = t.data();
    const char* e = b + t.size();
    if (t.find_first_of(".eE") == std::string_view::npos) {
      if (t.front() == '-') {
        int64_t i = 0;
        if (std::from_chars(b, e, i).ec == std::errc()) return Json(i);
      } else {
        uint64_t u = 0;
        if (std::from_chars(b, e, u).ec == std::errc()) return Json(u);
      }
    }
    double d = 0.0;
    const auto r = std::from_chars(b, e, d);
    if (r.ec == std::errc::result_out_of_range) {
      // Overflow is an error; underflow (1e-400) reads as the nearest double (0 or a subnormal), as strtod does.
      d = std::strtod(std::string(t).c_str(), nullptr);
      if (!std::isfinite(d)) fail(path(), "must be finite (number too large for a double)");
    } else if (r.ec != std::errc() || r.ptr != e) {
      fail(path(), "malformed number " + shown(std::string(t)));
    }
    return Json(d);
  }

  void record(Event::Kind kind, std::string_view text = {}) {
    Event& e = events_.emplace_back();
    e.kind = kind;
    if (!text.empty()) {
      e.text = text_.size();
      e.length = text.size();
      text_.append(text);
    }
  }
  std::string_view text_of(const Event& e) const { return std::string_view(text_).substr(e.text, e.length); }

  void scalar(Json&& v) {
    if (!recording_) return add(std::move(v));
    if (v.is_boolean()) {
      record(Event::Bool);
      events_.back().boolean = v.get<bool>();
    } else {
      record(v.is_null() ? Event::Null : Event::Number);
      events_.back().number = std::move(v);
    }
    element_done();
  }
  void key(std::string_view k) {
    Frame& f = frames_.back();
    f.key.assign(k);
    if (f.value && !f.unique_key()) fail(path(), "duplicate key");
  }
  void start(bool array) {
    if (frames_.size() >= kMaxSceneNesting)
      fail(path(), "nested deeper than " + std::to_string(kMaxSceneNesting) + " levels");
    if (!recording_ && !replaying_ && !array && !frames_.empty() && frames_.back().shapes) {  // a shape begins
      recording_ = true;
      events_.clear();
      text_.clear();
    }
    if (recording_) {
      record(array ? Event::StartArray : Event::StartObject);
      frames_.push_back({nullptr, array, false, 0, {}, {}});
      return;
    }
    const bool shapes = array && frames_.size() == 1 && !frames_[0].array && frames_[0].key == "shapes";
    Json* v = place(array ? Json::array() : Json::object());
    frames_.push_back({v, array, shapes, 0, {}, {}});
  }
  void end() {
    if (!recording_) return close();
    record(frames_.back().array ? Event::EndArray : Event::EndObject);
    frames_.pop_back();
    if (!frames_.back().shapes) return element_done();
    recording_ = false;  // the shape is complete
    ShapeDesc shape;
    std::string_view material;
    if (read_plain_shape(shape, material)) {
      parsed_sink_(shape, material, frames_.back().index);
      ++frames_.back().index;
      return;
    }
    replay();  // builds the element's tree; its completion hands it to tree_sink_
  }

  // Reads the recorded shape when it is in the plain form: {"type": ..., "vertices": [[x, y, z], ...],
  // "material": ...} or {"type": "sphere", "center": [x, y, z], "radius": r, "material": ...}, keys in any order,
  // each once, numbers finite. Anything else returns false, and read_shape reads the tree (with the same result
  // for what it accepts, and the reason for what it refuses).
  bool read_plain_shape(ShapeDesc& s, std::string_view& material) const {
    size_t i = 1;  // events_[0] is StartObject
    const auto num = [&](double& out) {
      if (events_[i].kind != Event::Number) return false;
      out = events_[i++].number.get<double>();
      return std::isfinite(out);
    };
    const auto triple = [&](DVec3& out) {
      if (events_[i].kind != Event::StartArray) return false;
      ++i;
      if (!num(out.x) || !num(out.y) || !num(out.z) || events_[i].kind != Event::EndArray) return false;
      ++i;
      return true;
    };
    bool type = false, vertices = false, center = false, radius = false, named = false;
    size_t n = 0;
    while (events_[i].kind == Event::Key) {
      const std::string_view k = text_of(events_[i++]);
      if (k == "type" && !type) {
        if (events_[i].kind != Event::String || !parse_enum(text_of(events_[i++]), s.type)) return false;
        type = true;
      } else if (k == "material" && !named) {
        if (events_[i].kind != Event::String) return false;
        material = text_of(events_[i++]);
        named = true;
      } else if (k == "vertices" && !vertices) {
        if (events_[i++].kind != Event::StartArray) return false;
        for (; events_[i].kind == Event::StartArray; ++n)
          if (n == 4 || !triple(s.vertices[n])) return false;
        if (events_[i++].kind != Event::EndArray) return false;
        vertices = true;
      } else if (k == "center" && !center) {
        if (!triple(s.center)) return false;
        center = true;
      } else if (k == "radius" && !radius) {
        if (!num(s.radius)) return false;
        radius = true;
      } else {
        return false;
      }
    }
    if (events_[i].kind != Event::EndObject || i + 1 != events_.size() || !type || !named) return false;
    if (s.type == ShapeType::Sphere) return center && radius && !vertices;
    return vertices && !center && !radius && n == (s.type == ShapeType::Triangle ? 3u : 4u);
  }

  // Builds the recorded shape's tree through the normal handler path.
  void replay() {
    replaying_ = true;
    for (const Event& e : events_) {
      switch (e.kind) {
        case Event::Null: add(Json(nullptr)); break;
        case Event::Bool: add(Json(e.boolean)); break;
        case Event::Number: add(Json(e.number)); break;
        case Event::String: add(Json(std::string(text_of(e)))); break;
        case Event::Key: key(text_of(e)); break;
        case Event::StartObject: start(false); break;
        case Event::StartArray: start(true); break;
        case Event::EndObject:
        case Event::EndArray: close(); break;
      }
    }
    replaying_ = false;
  }

  // Places v where the reader is (the root, the next array element, or the member of the last key) and returns
  // where it went.
  Json* place(Json&& v) {
    if (frames_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    Frame& f = frames_.back();
    if (f.array) {  // f.index advances once the element is complete (element_done)
      auto& elements = f.value->get_ref<Json::array_t&>();
      elements.push_back(std::move(v));
      return &elements.back();
    }
    auto& members = static_cast<std::vector<std::pair<const std::string, Json>>&>(f.value->get_ref<Json::object_t&>());
    members.emplace_back(f.key, std::move(v));
    return &members.back().second;
  }
  void element_done() {
    if (frames_.empty() || !frames_.back().array) return;
    Frame& f = frames_.back();
    if (f.shapes) {
      auto& elements = f.value->get_ref<Json::array_t&>();
      tree_sink_(elements.back(), f.index);
      elements.pop_back();
    }
    ++f.index;
  }
  void add(Json&& v) {
    place(std::move(v));
    element_done();
  }
  void close() {
    frames_.pop_back();
    element_done();
  }

  Json& root_;
  ParsedShapeSink parsed_sink_;
  ShapeTreeSink tree_sink_;
  std::vector<Frame> frames_;
  bool recording_ = false, replaying_ = false;
  std::vector<Event> events_;
  std::string text_;
  std::optional<PathError> error_;
};

// ---------------------------------------------------------------------------------------------------------------
// Typed readers. Each takes the JSON value and its path and either returns the value or fails with the path.

const Json& expect_object(const Json& v, const std::string& path) {
  if (!v.is_object()) fail(path, "expected an object, " + got(v));
  return v;
}

const Json* optional_key(const Json& obj, const char* key) {
  const auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

const Json& required_key(const Json& obj, const std::string& path, const char* key) {
  if (const Json* v = optional_key(obj, key)) return *v;
  fail(member(path, key), "missing required key");
}

// Every key must be one of `known`; the message lists them.
void check_known_keys(const Json& obj, const std::string& path, std::initializer_list<const char*> known) {
  for (const auto& item : obj.items()) {
    bool found = false;
    for (const char* k : known) found = found || item.key() == k;
    if (!found) fail(member(path, item.key()), "unknown key (expected one of: " + join_names(known) + ")");
  }
}

// Keys that are known but do not apply to this variant (e.g. "ior" on a diffuse material).
void check_applicable_keys(const Json& obj, const std::string& path, const std::vector<const char*>& applicable,
                           const std::string& variant) {
  for (const auto& item : obj.items()) {
    bool found = false;
    for (const char* k : applicable) found = found || item.key() == k;
    if (!found) fail(member(path, item.key()), "does not apply to " + variant);
  }
}

double read_double(const Json& v, const std::string& path) {
  if (!v.is_number()) fail(path, "expected a number, " + got(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail(path, "must be finite");
  return d;
}

float read_float(const Json& v, const std::string& path) {
  const double d = read_double(v, path);
  // Values from FLT_MAX up to half an ulp above it round to FLT_MAX ("3.4028235e+38" is FLT_MAX); beyond, to inf.
  if (std::fabs(d) >= 0x1.ffffffp127) fail(path, "must be finite (out of single-precision range)");
  return static_cast<float>(d);
}

// An integer: a JSON integer, or a number with an integral value (512.0, 1e3).
int read_int(const Json& v, const std::string& path) {
  if (!v.is_number()) fail(path, "expected an integer, " + got(v));
  if (v.is_number_unsigned()) {
    const uint64_t u = v.get<uint64_t>();
    if (u > static_cast<uint64_t>(INT_MAX)) fail(path, "integer out of range");
    return static_cast<int>(u);
  }
  if (v.is_number_integer()) {
    const int64_t i = v.get<int64_t>();
    if (i < INT_MIN || i > INT_MAX) fail(path, "integer out of range");
    return static_cast<int>(i);
  }
  const double d = v.get<double>();
  if (!std::isfinite(d) || d != std::trunc(d)) fail(path, "expected an integer, got " + v.dump());
  if (d < static_cast<double>(INT_MIN) || d > static_cast<double>(INT_MAX)) fail(path, "integer out of range");
  return static_cast<int>(d);
}

uint64_t read_uint64(const Json& v, const std::string& path) {
  if (!v.is_number()) fail(path, "expected a non-negative integer, " + got(v));
  if (v.is_number_unsigned()) return v.get<uint64_t>();
  if (v.is_number_integer()) {
    const int64_t i = v.get<int64_t>();
    if (i < 0) fail(path, "must be a non-negative integer, got " + v.dump());
    return static_cast<uint64_t>(i);
  }
  const double d = v.get<double>();
  if (!std::isfinite(d) || d != std::trunc(d)) fail(path, "expected a non-negative integer, got " + v.dump());
  if (d < 0.0) fail(path, "must be a non-negative integer, got " + v.dump());
  if (d >= 18446744073709551616.0) fail(path, "integer out of range");
  return static_cast<uint64_t>(d);
}

bool read_bool(const Json& v, const std::string& path) {
  if (!v.is_boolean()) fail(path, "expected true or false, " + got(v));
  return v.get<bool>();
}

const std::string& read_string(const Json& v, const std::string& path) {
  if (!v.is_string()) fail(path, "expected a string, " + got(v));
  return v.get_ref<const std::string&>();
}

const Json& expect_triple(const Json& v, const std::string& path) {
  if (!v.is_array()) fail(path, "expected an array of 3 numbers, " + got(v));
  if (v.size() != 3) fail(path, "expected an array of 3 numbers, got " + std::to_string(v.size()) + " elements");
  return v;
}

DVec3 read_dvec3(const Json& v, const std::string& path) {
  expect_triple(v, path);
  return {read_double(v[0], element(path, 0)), read_double(v[1], element(path, 1)),
          read_double(v[2], element(path, 2))};
}

Rgb read_rgb(const Json& v, const std::string& path) {
  expect_triple(v, path);
  return {read_float(v[0], element(path, 0)), read_float(v[1], element(path, 1)), read_float(v[2], element(path, 2))};
}

// Reads an enum by its table's name (core/enum_table.h); the error lists the accepted names.
template <class E>
E read_enum(const Json& v, const std::string& path, const char* noun) {
  const std::string& s = read_string(v, path);
  E value;
  if (parse_enum(s, value)) return value;
  fail(path, "unknown " + std::string(noun) + " " + shown_quoted(s) + " (expected one of: " + enum_names_joined<E>() + ")");
}

// ---------------------------------------------------------------------------------------------------------------
// The schema.

CameraDesc read_camera(const Json& j, const std::string& path) {
  expect_object(j, path);
  check_known_keys(j, path, {"position", "look_at", "up", "fov_deg", "fov_axis", "aperture_radius", "focus_distance"});
  CameraDesc c;
  c.position = read_dvec3(required_key(j, path, "position"), member(path, "position"));
  c.look_at = read_dvec3(required_key(j, path, "look_at"), member(path, "look_at"));
  c.up = DVec3(0, 1, 0);
  if (const Json* v = optional_key(j, "up")) c.up = read_dvec3(*v, member(path, "up"));
  c.fov_deg = read_double(required_key(j, path, "fov_deg"), member(path, "fov_deg"));
  c.fov_axis = FovAxis::Vertical;
  if (const Json* v = optional_key(j, "fov_axis")) c.fov_axis = read_enum<FovAxis>(*v, member(path, "fov_axis"), "fov_axis");
  if (const Json* v = optional_key(j, "aperture_radius")) c.aperture_radius = read_double(*v, member(path, "aperture_radius"));
  if (const Json* v = optional_key(j, "focus_distance")) c.focus_distance = read_double(*v, member(path, "focus_distance"));
  return c;
}

void read_film(const Json& j, const std::string& path, SceneDesc& s) {
  expect_object(j, path);
  check_known_keys(j, path, {"width", "height"});
  if (const Json* v = optional_key(j, "width")) s.width = read_int(*v, member(path, "width"));
  if (const Json* v = optional_key(j, "height")) s.height = read_int(*v, member(path, "height"));
}

RenderSettings read_render(const Json& j, const std::string& path) {
  expect_object(j, path);
  check_known_keys(j, path, {"max_bounces", "estimator", "sampler", "russian_roulette_depth", "seed"});
  RenderSettings r;
  if (const Json* v = optional_key(j, "max_bounces")) r.max_bounces = read_int(*v, member(path, "max_bounces"));
  if (const Json* v = optional_key(j, "estimator"))
    r.estimator = read_enum<Estimator>(*v, member(path, "estimator"), "estimator");
  if (const Json* v = optional_key(j, "sampler"))
    r.sampler = read_enum<SamplerType>(*v, member(path, "sampler"), "sampler");
  if (const Json* v = optional_key(j, "russian_roulette_depth")) {
    const std::string where = member(path, "russian_roulette_depth");
    if (v->is_string() && v->get<std::string>() == "auto") {
      r.russian_roulette_depth = kRouletteDepthAuto;
    } else {
      r.russian_roulette_depth = read_int(*v, where);
      if (r.russian_roulette_depth < -1) fail(where, "must be >= 0, -1 for off, or \"auto\"");
    }
  }
  if (const Json* v = optional_key(j, "seed")) r.seed = read_uint64(*v, member(path, "seed"));
  return r;
}

MaterialDesc read_material(const std::string& name, const Json& j, const std::string& path, const std::string& base_dir) {
  expect_object(j, path);
  check_known_keys(j, path, {"type", "albedo", "emission", "two_sided", "ior", "roughness", "g", "metal", "eta", "k",
                             "metallic", "albedo_texture"});
  MaterialDesc m;
  m.name = name;
  m.type = read_enum<MaterialType>(required_key(j, path, "type"), member(path, "type"), "material type");
  const std::string variant = std::string("a ") + to_string(m.type) + " material";
  // The keys this type takes (kMaterialParams, materials/material.h); any other known key is refused by name.
  std::vector<const char*> applicable{"type", "emission", "two_sided"};
  if (takes(m.type, MaterialParam::Albedo)) applicable.insert(applicable.end(), {"albedo", "albedo_texture"});
  if (takes(m.type, MaterialParam::Metal)) applicable.insert(applicable.end(), {"metal", "eta", "k"});
  if (takes(m.type, MaterialParam::Ior)) applicable.push_back("ior");
  if (takes(m.type, MaterialParam::Roughness)) applicable.push_back("roughness");
  if (takes(m.type, MaterialParam::G)) applicable.push_back("g");
  if (takes(m.type, MaterialParam::Metallic)) applicable.push_back("metallic");
  check_applicable_keys(j, path, applicable, variant);
  if (m.type == MaterialType::Mirror) m.albedo = Rgb(1.f);     // a mirror's default tint: none
  if (m.type == MaterialType::Subsurface) m.ior = 1.3f;        // skin, wax, milk: ~1.3-1.4
  if (takes(m.type, MaterialParam::Metal)) {
    const int given = (optional_key(j, "albedo") ? 1 : 0) + (optional_key(j, "metal") ? 1 : 0) +
                      (optional_key(j, "eta") || optional_key(j, "k") ? 1 : 0);
    if (given > 1) fail(path, "a conductor takes one of: albedo, metal, or eta and k");
    if (const Json* v = optional_key(j, "metal"))
      m.metal = read_enum<MetalPreset>(*v, member(path, "metal"), "metal");
    if (optional_key(j, "eta") || optional_key(j, "k")) {
      m.complex_ior = true;
      m.eta = read_rgb(required_key(j, path, "eta"), member(path, "eta"));
      m.k = read_rgb(required_key(j, path, "k"), member(path, "k"));
    }
  }
  if (const Json* v = optional_key(j, "albedo")) m.albedo = read_rgb(*v, member(path, "albedo"));
  if (const Json* v = optional_key(j, "ior")) m.ior = read_float(*v, member(path, "ior"));
  if (const Json* v = optional_key(j, "roughness")) m.roughness = read_float(*v, member(path, "roughness"));
  if (const Json* v = optional_key(j, "g")) m.g = read_float(*v, member(path, "g"));
  if (const Json* v = optional_key(j, "metallic")) m.metallic = read_float(*v, member(path, "metallic"));
  if (const Json* v = optional_key(j, "emission")) m.emission = read_rgb(*v, member(path, "emission"));
  if (const Json* v = optional_key(j, "two_sided")) m.two_sided = read_bool(*v, member(path, "two_sided"));
  if (const Json* v = optional_key(j, "albedo_texture")) {
    // An image file (relative to the scene file's folder) whose colours replace the albedo (materials/texture.h).
    const std::string at = member(path, "albedo_texture");
    m.albedo_texture = read_string(*v, at);
    if (m.albedo_texture.empty()) fail(at, "must not be empty");
    const std::filesystem::path file(m.albedo_texture);
    m.resolved_albedo_texture =
        file.is_absolute() || base_dir.empty() ? m.albedo_texture : (std::filesystem::path(base_dir) / file).string();
    if (!optional_key(j, "albedo")) m.albedo = Rgb(1.f);  // with a texture, albedo is its factor
    try {
      m.albedo_map = load_texture_file(m.resolved_albedo_texture, true);
    } catch (const ImageError& e) {
      fail(at, e.what());
    }
    if (std::string err = validate_material(m); !err.empty()) fail(path, err);
  }
  return m;
}

// A radiance: finite and in [0, kMaxRadiance] in every channel (checked here so the message names the key the file used).
Rgb read_radiance(const Json& v, const std::string& path) {
  const Rgb c = read_rgb(v, path);
  if (const std::string why = radiance_problem(c); !why.empty()) fail(path, why);
  return c;
}

// The environment object; "background": [r, g, b] is the shorthand for a constant one.
EnvironmentDesc read_environment(const Json& j, const std::string& path, const std::string& base_dir) {
  expect_object(j, path);
  check_known_keys(j, path, {"type", "radiance", "sun_direction", "turbidity", "sun", "scale", "file", "rotation_deg"});
  EnvironmentDesc e;
  e.type = read_enum<EnvironmentType>(required_key(j, path, "type"), member(path, "type"), "environment type");
  const std::string variant = std::string("a ") + to_string(e.type) + " environment";
  switch (e.type) {
    case EnvironmentType::Constant:
      check_applicable_keys(j, path, {"type", "radiance"}, variant);
      e.radiance = read_radiance(required_key(j, path, "radiance"), member(path, "radiance"));
      break;
    case EnvironmentType::Sky:
      check_applicable_keys(j, path, {"type", "sun_direction", "turbidity", "sun", "scale"}, variant);
      if (const Json* v = optional_key(j, "sun_direction")) e.sun_direction = read_dvec3(*v, member(path, "sun_direction"));
      if (const Json* v = optional_key(j, "turbidity")) e.turbidity = read_float(*v, member(path, "turbidity"));
      if (const Json* v = optional_key(j, "sun")) e.sun = read_bool(*v, member(path, "sun"));
      break;
    case EnvironmentType::Map: {
      check_applicable_keys(j, path, {"type", "file", "scale", "rotation_deg"}, variant);
      e.file = read_string(required_key(j, path, "file"), member(path, "file"));
      if (e.file.empty()) fail(member(path, "file"), "must not be empty");
      if (const Json* v = optional_key(j, "rotation_deg")) e.rotation_deg = read_float(*v, member(path, "rotation_deg"));
      const std::filesystem::path file(e.file);
      e.resolved_file = file.is_absolute() || base_dir.empty() ? e.file : (std::filesystem::path(base_dir) / file).string();
      HdrImageResult read = read_hdr_image(e.resolved_file);
      if (!read.ok()) fail(member(path, "file"), read.error);
      e.image = std::make_shared<Image>(std::move(read.image));
      break;
    }
  }
  if (const Json* v = optional_key(j, "scale")) e.scale = read_float(*v, member(path, "scale"));
  return e;
}

// A shape's geometry at `path`: an element of "shapes", or of a group's "shapes" (whose caller has refused a
// "material" key). Shapes in the plain form never come here (SceneSax reads them directly): this reader gives
// the reasons for the rest.
ShapeDesc read_shape_geometry(const Json& j, const std::string& path) {
  expect_object(j, path);
  check_known_keys(j, path, {"type", "vertices", "center", "radius", "material"});
  ShapeDesc s;
  s.type = read_enum<ShapeType>(required_key(j, path, "type"), member(path, "type"), "shape type");
  const std::string type_name = to_string(s.type);
  if (s.type == ShapeType::Sphere) {
    check_applicable_keys(j, path, {"type", "center", "radius", "material"}, "a sphere");
    s.center = read_dvec3(required_key(j, path, "center"), member(path, "center"));
    s.radius = read_double(required_key(j, path, "radius"), member(path, "radius"));
  } else {
    check_applicable_keys(j, path, {"type", "vertices", "material"}, "a " + type_name);
    const size_t n = s.type == ShapeType::Triangle ? 3 : 4;
    const std::string vpath = member(path, "vertices");
    const Json& v = required_key(j, path, "vertices");
    if (!v.is_array()) fail(vpath, "expected an array of " + std::to_string(n) + " points, " + got(v));
    if (v.size() != n)
      fail(vpath, "a " + type_name + " has exactly " + std::to_string(n) + " vertices, got " + std::to_string(v.size()));
    for (size_t k = 0; k < n; ++k) s.vertices[k] = read_dvec3(v[k], element(vpath, k));
  }
  return s;
}

// One element of "shapes"; its material is returned by name in `material_name` (materials may come later in
// the file).
ShapeDesc read_shape(const Json& j, size_t index, const std::string*& material_name) {
  const std::string path = element("shapes", index);
  ShapeDesc s = read_shape_geometry(j, path);
  material_name = &read_string(required_key(j, path, "material"), member(path, "material"));
  return s;
}

// An object's optional "transform" (scene/object_transform.h).
ObjectTransform read_transform(const Json& j, const std::string& path) {
  ObjectTransform t;
  const Json* tr = optional_key(j, "transform");
  if (!tr) return t;
  const std::string tp = member(path, "transform");
  expect_object(*tr, tp);
  check_known_keys(*tr, tp, {"scale", "rotate_axis", "rotate_deg", "translate"});
  if (const Json* v = optional_key(*tr, "scale")) {
    const std::string sp = member(tp, "scale");
    t.scale = v->is_array() ? read_dvec3(*v, sp) : DVec3(read_double(*v, sp));
    if (t.scale.x == 0.0 || t.scale.y == 0.0 || t.scale.z == 0.0) fail(sp, "must not be 0 (it flattens the object)");
  }
  if (const Json* v = optional_key(*tr, "rotate_axis")) {
    t.axis = read_dvec3(*v, member(tp, "rotate_axis"));
    if (!(glm::length(t.axis) > 0.0)) fail(member(tp, "rotate_axis"), "must not be the zero vector");
  }
  if (const Json* v = optional_key(*tr, "rotate_deg")) t.degrees = read_double(*v, member(tp, "rotate_deg"));
  if (const Json* v = optional_key(*tr, "translate")) t.translate = read_dvec3(*v, member(tp, "translate"));
  return t;
}

// The shapes as the reader streams them. Each shape's `material` holds a provisional id per distinct name (in
// order of first use) until resolve() maps the ids to the material table.
struct StreamedShapes {
  // Names are looked up as string_views (no string built per shape).
  struct NameHash {
    using is_transparent = void;
    size_t operator()(std::string_view s) const { return std::hash<std::string_view>()(s); }
  };
  std::vector<ShapeDesc> shapes;
  std::vector<TriangleShading> shading;  // the models' vertex normals (ShapeDesc::shading)
  std::unordered_map<std::string, int, NameHash, std::equal_to<>> ids;
  std::vector<const std::string*> names;  // by id (keys of `ids`, whose addresses are stable)
  std::vector<size_t> first_use;          // by id: the first shape that names it, for the error message

  // A triangle's vertex normals and uv into `shading`: its index there, or kNoShading for one without either.
  uint32_t add_shading(const TriangleShading& t) {
    if (!t.any()) return kNoShading;
    shading.push_back(t);
    return static_cast<uint32_t>(shading.size() - 1);
  }
  // The id of a material name (resolve() maps ids to the scene's materials).
  int material_id(std::string_view material, size_t index) {
    auto it = ids.find(material);
    if (it == ids.end()) {
      it = ids.emplace(std::string(material), static_cast<int>(names.size())).first;
      names.push_back(&it->first);
      first_use.push_back(index);
    }
    return it->second;
  }
  void add(ShapeDesc s, std::string_view material, size_t index) {
    s.material = material_id(material, index);
    shapes.push_back(s);
  }
  void add(const Json& j, size_t index) {
    if (j.is_object()) {
      const auto type = j.find("type");
      if (type != j.end() && type->is_string() && type->get_ref<const std::string&>() == "mesh")
        return add_mesh(j, index);
      if (type != j.end() && type->is_string() && type->get_ref<const std::string&>() == "group")
        return add_group(j, index);
      if (type != j.end() && type->is_string() && type->get_ref<const std::string&>() == "gltf")
        return add_gltf(j, index);
    }
    const std::string* name = nullptr;
    const ShapeDesc s = read_shape(j, index, name);
    add(s, *name, index);
  }

  // {"type": "mesh", "name": ..., "file": "x.obj", "material": ..., "transform": {...}}: one object, the OBJ
  // file's triangles each a shape. Without "material", the faces take the file's .mtl materials as a glTF
  // model's take its own (below); an OBJ without a material library then needs "material".
  void add_mesh(const Json& j, size_t index) {
    const std::string path = element("shapes", index);
    check_known_keys(j, path, {"type", "name", "file", "material", "transform"});
    ObjectDesc o = model_object(j, path, ObjectKind::Mesh);
    const std::string* override_name = model_material(j, path);
    MeshTriangles mesh;
    try {
      mesh = load_obj_mesh(o.resolved_file, o.transform);
    } catch (const std::bad_alloc&) {
      throw;  // out of memory is no fault of the file: exit status 3, not 2
    } catch (const std::exception& e) {
      fail(member(path, "file"), e.what());
    }
    if (!override_name && mesh.materials.empty())
      fail(member(path, "material"), "required: the OBJ file names no material library (mtllib) to take its materials from");
    for (const std::string& w : mesh.warnings) warnings.push_back(w.rfind(o.resolved_file, 0) == 0 ? w : o.resolved_file + ": " + w);
    // Texture files the .mtl names (found beside the OBJ) are written as the scene file would name them: from
    // the mesh's own file name.
    const std::filesystem::path obj_dir = std::filesystem::path(o.resolved_file).parent_path();
    for (MaterialDesc& m : mesh.materials)
      if (!m.albedo_texture.empty())
        m.albedo_texture = (std::filesystem::path(o.file).parent_path() /
                            std::filesystem::path(m.resolved_albedo_texture).lexically_relative(obj_dir))
                               .generic_string();
    // Faces that name no material take the .mtl format's default (diffuse, Kd 0.8), as "NAME/default".
    const bool unassigned = std::find(mesh.triangle_material.begin(), mesh.triangle_material.end(), -1) != mesh.triangle_material.end();
    if (unassigned) {
      MaterialDesc d;
      d.name = "default";
      mesh.materials.push_back(d);
      for (int& m : mesh.triangle_material)
        if (m < 0) m = static_cast<int>(mesh.materials.size() - 1);
    }
    const std::vector<std::string> names = file_material_names(o, mesh.materials, override_name, path);
    o.first_shape = shapes.size();
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      ShapeDesc s;
      s.type = ShapeType::Triangle;
      for (int k = 0; k < 3; ++k) s.vertices[k] = mesh.triangles[t][k];
      if (!mesh.shading.empty()) s.shading = add_shading(mesh.shading[t]);
      add(s, override_name ? std::string_view(*override_name) : std::string_view(names[mesh.triangle_material[t]]), index);
    }
    o.shape_count = shapes.size() - o.first_shape;
    objects.push_back(std::move(o));
  }

  // {"type": "gltf", "name": ..., "file": "x.glb", "transform": {...}, "material": ...}: one object, the glTF
  // file's triangles (scene/gltf_import.h) placed by the transform, each keeping the file's material under the
  // name "NAME/MATERIAL" (NAME the object's); a material of that name in the scene's materials overrides the
  // file's (so edits saved from the viewer come back), and "material", when given, replaces them all.
  void add_gltf(const Json& j, size_t index) {
    const std::string path = element("shapes", index);
    check_known_keys(j, path, {"type", "name", "file", "material", "transform"});
    ObjectDesc o = model_object(j, path, ObjectKind::Gltf);
    const std::string* override_name = model_material(j, path);
    GltfContents model;
    try {
      model = load_gltf(o.resolved_file);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      fail(member(path, "file"), e.what());
    }
    for (const std::string& w : model.warnings) warnings.push_back(o.resolved_file + ": " + w);
    for (PunctualLightDesc& l : model.lights) {  // placed by this object's transform, as its shapes are
      l.object = static_cast<int>(objects.size());
      lights.push_back(std::move(l));
    }
    const std::vector<std::string> names = file_material_names(o, model.materials, override_name, path);
    o.first_shape = shapes.size();
    for (size_t t = 0; t < model.triangles.size(); ++t) {
      ShapeDesc s;
      s.type = ShapeType::Triangle;
      for (int k = 0; k < 3; ++k) s.vertices[k] = model.triangles[t][k];
      if (!model.shading.empty()) s.shading = add_shading(model.shading[t]);
      if (!transform_shape(s, o.transform, true)) fail(member(path, "transform"), "cannot place the model");
      add(s, override_name ? std::string_view(*override_name) : std::string_view(names[model.triangle_material[t]]), index);
    }
    o.shape_count = shapes.size() - o.first_shape;
    // Its meshes (all but the emitting ones): stored once, placed by instances of this object (its transform applies).
    const size_t first_mesh = meshes.size();
    for (GltfMesh& g : model.meshes) meshes.push_back(std::make_shared<const MeshDesc>(std::move(g.mesh)));
    for (const GltfInstance& gi : model.instances) {
      InstanceDesc in;
      in.mesh = static_cast<uint32_t>(first_mesh + gi.mesh);
      in.transform = gi.transform;
      in.object = static_cast<int>(objects.size());
      for (int m : model.meshes[gi.mesh].slot_material)
        in.materials.push_back(material_id(override_name ? std::string_view(*override_name) : std::string_view(names[m]), index));
      instances.push_back(std::move(in));
    }
    objects.push_back(std::move(o));
  }

  // A model's "material" (one scene material for all its triangles), or null: its file's materials then.
  const std::string* model_material(const Json& j, const std::string& path) const {
    const Json* material = optional_key(j, "material");
    return material ? &read_string(*material, member(path, "material")) : nullptr;
  }

  // The names a model file's materials take in the scene, "NAME/MATERIAL" (NAME the object's); unless one scene
  // material replaces them all, they join the scene's materials (where a scene material of the same name, an
  // edit saved from the viewer, overrides the file's).
  std::vector<std::string> file_material_names(const ObjectDesc& o, const std::vector<MaterialDesc>& materials,
                                               const std::string* override_name, const std::string& path) {
    if (!override_name && o.name.find('/') != std::string::npos)
      fail(member(path, "name"), "must not contain '/' (it names the materials)");
    std::vector<std::string> names(materials.size());
    for (size_t m = 0; m < materials.size(); ++m) {
      names[m] = o.name + "/" + materials[m].name;
      if (!override_name) {
        MaterialDesc d = materials[m];
        d.name = names[m];
        imported.push_back(std::move(d));
      }
    }
    return names;
  }

  // {"type": "group", "name": ..., "material": ..., "transform": {...}, "shapes": [...]}: one object, its
  // shapes (triangles, quads, spheres without a material of their own) in the group's coordinates.
  void add_group(const Json& j, size_t index) {
    const std::string path = element("shapes", index);
    check_known_keys(j, path, {"type", "name", "material", "transform", "shapes"});
    const std::string& material = read_string(required_key(j, path, "material"), member(path, "material"));
    ObjectDesc o;
    o.kind = ObjectKind::Group;
    o.name = object_name(j, path, "group " + std::to_string(objects.size() + 1));
    o.transform = read_transform(j, path);
    const std::string list_path = member(path, "shapes");
    const Json& list = required_key(j, path, "shapes");
    if (!list.is_array()) fail(list_path, "expected an array of shapes, " + got(list));
    if (list.empty()) fail(list_path, "a group holds at least one shape");
    o.first_shape = shapes.size();
    for (size_t k = 0; k < list.size(); ++k) {
      const std::string shape_path = element(list_path, k);
      if (list[k].is_object() && list[k].contains("material"))
        fail(member(shape_path, "material"), "a group's shapes take the group's material");
      ShapeDesc s = read_shape_geometry(list[k], shape_path);
      if (!transform_shape(s, o.transform, true))
        fail(member(path, "transform"), "a group with a sphere takes the same scale on every axis");
      add(s, material, index);
    }
    o.shape_count = shapes.size() - o.first_shape;
    objects.push_back(std::move(o));
  }

  // What a model read from a file (mesh, gltf) takes from its element: the file (relative paths lead from the
  // scene file's folder), the name (default the file's stem) and the transform.
  ObjectDesc model_object(const Json& j, const std::string& path, ObjectKind kind) const {
    const std::string& file = read_string(required_key(j, path, "file"), member(path, "file"));
    if (file.empty()) fail(member(path, "file"), "must not be empty");
    ObjectDesc o;
    o.kind = kind;
    o.name = object_name(j, path, std::filesystem::path(file).stem().string());
    o.transform = read_transform(j, path);
    o.file = file;
    const std::filesystem::path f(file);
    o.resolved_file = f.is_absolute() || base_dir.empty() ? file : (std::filesystem::path(base_dir) / f).string();
    return o;
  }

  static std::string object_name(const Json& j, const std::string& path, std::string fallback) {
    const Json* v = optional_key(j, "name");
    if (!v) return fallback;
    const std::string& name = read_string(*v, member(path, "name"));
    if (name.empty()) fail(member(path, "name"), "must not be empty (leave the key out for the default name)");
    return name;
  }

  std::vector<ObjectDesc> objects;  // in shape order
  std::vector<std::shared_ptr<const MeshDesc>> meshes;  // glTF models' meshes (instanced)
  std::vector<InstanceDesc> instances;                  // their placements (materials as name ids until resolve)
  std::vector<PunctualLightDesc> lights;  // glTF models' punctual lights
  std::string base_dir;  // where relative mesh paths start (the scene file's directory)
  std::vector<MaterialDesc> imported;  // glTF models' materials, named "OBJECT/MATERIAL"
  std::vector<std::string> warnings;   // what the glTF files hold that is not read (printed by load_scene_file)

  void resolve(const std::unordered_map<std::string, int>& material_index) {
    std::vector<int> index_of(names.size());
    for (size_t id = 0; id < names.size(); ++id) {
      const auto it = material_index.find(*names[id]);
      if (it == material_index.end())
        fail(member(element("shapes", first_use[id]), "material"), "unknown material " + shown_quoted(*names[id]));
      index_of[id] = it->second;
    }
    for (ShapeDesc& s : shapes) s.material = index_of[s.material];
    for (InstanceDesc& in : instances)
      for (int& m : in.materials) m = index_of[m];
  }
};

SceneDesc read_scene(const Json& root, const std::string& base_dir, StreamedShapes& streamed) {
  if (!root.is_object()) fail("", "the top level must be an object, " + got(root));
  check_known_keys(root, "", {"camera", "film", "render", "background", "environment", "materials", "shapes"});
  SceneDesc s;
  s.camera = read_camera(required_key(root, "", "camera"), "camera");
  if (const Json* v = optional_key(root, "film")) read_film(*v, "film", s);
  if (const Json* v = optional_key(root, "render")) s.render = read_render(*v, "render");
  if (optional_key(root, "background") && optional_key(root, "environment"))
    fail("background", "give either background (a constant environment) or environment, not both");
  if (const Json* v = optional_key(root, "background")) s.environment.radiance = read_radiance(*v, "background");
  if (const Json* v = optional_key(root, "environment")) s.environment = read_environment(*v, "environment", base_dir);

  const Json& materials = expect_object(required_key(root, "", "materials"), "materials");
  if (materials.empty() && streamed.imported.empty()) fail("materials", "must define at least one material");
  std::unordered_map<std::string, int> material_index;
  for (const auto& item : materials.items()) {
    if (item.key().empty()) fail("materials", "a material name must not be empty");
    material_index.emplace(item.key(), static_cast<int>(s.materials.size()));
    s.materials.push_back(read_material(item.key(), item.value(), "materials." + item.key(), base_dir));
  }
  // Model files' materials, unless the scene's materials already name them (an override, e.g. saved edits). A
  // texture that came inside the model file stays with its material: the override's own albedo_texture, when it
  // names one, replaces the base colour's; the data textures (metallic-roughness, normal map) always stay.
  for (MaterialDesc& m : streamed.imported) {
    const auto [it, added] = material_index.emplace(m.name, static_cast<int>(s.materials.size()));
    if (added) {
      s.materials.push_back(std::move(m));
    } else {
      MaterialDesc& over = s.materials[static_cast<size_t>(it->second)];
      if (!over.albedo_map && m.albedo_map && m.albedo_texture.empty() && takes(over.type, MaterialParam::Albedo) &&
          over.type != MaterialType::Subsurface) {
        over.albedo_map = m.albedo_map;
        over.albedo_uv_transform = m.albedo_uv_transform;
      }
      over.metallic_roughness_map = m.metallic_roughness_map;  // the model file's data textures stay with it
      over.normal_map = m.normal_map;
      over.normal_scale = m.normal_scale;
      over.cutout = m.cutout;
      over.emission_map = m.emission_map;
    }
  }

  const Json& shapes = required_key(root, "", "shapes");  // its elements were streamed (SceneSax)
  if (!shapes.is_array()) fail("shapes", "expected an array, " + got(shapes));
  if (streamed.shapes.empty() && streamed.instances.empty()) fail("shapes", "must contain at least one shape");
  streamed.resolve(material_index);
  s.shapes = std::move(streamed.shapes);
  s.objects = std::move(streamed.objects);
  s.meshes = std::move(streamed.meshes);
  s.instances = std::move(streamed.instances);
  s.punctual_lights = std::move(streamed.lights);
  if (!streamed.shading.empty())
    s.shading = std::make_shared<const std::vector<TriangleShading>>(std::move(streamed.shading));
  return s;
}

// ---------------------------------------------------------------------------------------------------------------
// Writing.

// Integral values are written as integers ("278", not "278.0"); the sign of −0 is kept.
bool integral(double d) { return d == std::trunc(d) && std::fabs(d) < 9007199254740992.0 && !(d == 0.0 && std::signbit(d)); }

Json number(double d) {
  if (!std::isfinite(d)) return nullptr;
  if (integral(d)) return static_cast<int64_t>(d);
  return d;  // nlohmann writes doubles in a form that parses back to the same double
}

// A float is written as its shortest decimal form ("0.725", not "0.7250000238418579"), provided that decimal read as
// a double and rounded to float gives the float back (the reader rounds decimal → double → float); otherwise exactly.
Json number(float f) {
  if (!std::isfinite(f)) return nullptr;
  if (integral(f)) return static_cast<int64_t>(f);
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, f);
  double d = 0.0;
  if (r.ec == std::errc() && std::from_chars(buf, r.ptr, d).ec == std::errc() && static_cast<float>(d) == f) return d;
  return static_cast<double>(f);
}

Json triple(DVec3 v) { return Json::array({number(v.x), number(v.y), number(v.z)}); }
Json triple(Rgb v) { return Json::array({number(v.x), number(v.y), number(v.z)}); }
bool positive_zero(float f) { return f == 0.f && !std::signbit(f); }

// A file the scene refers to, as a scene file written into `destination_dir` should name it: as it was written
// when absolute or when there is no destination; otherwise the way from that folder to where the file was found.
std::string file_reference(const std::string& file, const std::string& resolved,
                           const std::optional<std::string>& destination_dir) {
  namespace fs = std::filesystem;
  if (!destination_dir || file.empty() || fs::path(file).is_absolute()) return file;
  std::error_code ec;
  const fs::path found = fs::absolute(resolved.empty() ? file : resolved, ec).lexically_normal();
  const fs::path dest = fs::absolute(destination_dir->empty() ? "." : *destination_dir, ec).lexically_normal();
  if (ec) return file;
  const fs::path relative = found.lexically_relative(dest);
  return (relative.empty() ? found : relative).generic_string();
}

Json shape_json(const ShapeDesc& sh) {
  Json j = {{"type", to_string(sh.type)}};
  if (sh.type == ShapeType::Sphere) {
    j["center"] = triple(sh.center);
    j["radius"] = number(sh.radius);
  } else {
    Json v = Json::array();
    for (int k = 0; k < (sh.type == ShapeType::Triangle ? 3 : 4); ++k) v.push_back(triple(sh.vertices[k]));
    j["vertices"] = std::move(v);
  }
  return j;
}

Json transform_json(const ObjectTransform& t) {
  Json j = Json::object();
  if (t.scale != DVec3(1.0)) j["scale"] = t.scale.x == t.scale.y && t.scale.y == t.scale.z ? number(t.scale.x) : triple(t.scale);
  if (t.axis != DVec3(0.0, 1.0, 0.0)) j["rotate_axis"] = triple(t.axis);
  if (t.degrees != 0.0) j["rotate_deg"] = number(t.degrees);
  if (t.translate != DVec3(0.0)) j["translate"] = triple(t.translate);
  return j;
}

// A mesh: its file and transform (the triangles come from the file). A group: its shapes in its own coordinates.
Json object_json(const ObjectDesc& o, const std::vector<ShapeDesc>& shapes, const std::string& material,
                 const std::optional<std::string>& destination_dir) {
  Json j = {{"type", to_string(o.kind)}, {"name", o.name}};
  if (o.kind != ObjectKind::Group) j["file"] = file_reference(o.file, o.resolved_file, destination_dir);
  // A model file's triangles may name the file's materials ("NAME/MATERIAL", written among the materials,
  // where the reader finds them as overrides); one material of the scene's own given to all of them is written
  // here.
  if (o.kind == ObjectKind::Group || (!material.empty() && material.rfind(o.name + "/", 0) != 0)) j["material"] = material;
  if (Json t = transform_json(o.transform); !t.empty()) j["transform"] = std::move(t);
  if (o.kind == ObjectKind::Group) {
    Json list = Json::array();
    for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k) {
      ShapeDesc local = shapes[k];
      transform_shape(local, o.transform, false);
      list.push_back(shape_json(local));
    }
    j["shapes"] = std::move(list);
  }
  return j;
}

Json to_json(const SceneDesc& s, const std::optional<std::string>& destination_dir) {
  Json root = Json::object();
  const CameraDesc& c = s.camera;
  root["camera"] = {{"position", triple(c.position)},
                    {"look_at", triple(c.look_at)},
                    {"up", triple(c.up)},
                    {"fov_deg", number(c.fov_deg)},
                    {"fov_axis", to_string(c.fov_axis)}};
  if (c.aperture_radius > 0.0) root["camera"]["aperture_radius"] = number(c.aperture_radius);  // pinhole: unwritten
  if (c.focus_distance > 0.0) root["camera"]["focus_distance"] = number(c.focus_distance);
  root["film"] = {{"width", s.width}, {"height", s.height}};
  root["render"] = {{"max_bounces", s.render.max_bounces},
                    {"estimator", to_string(s.render.estimator)},
                    {"sampler", to_string(s.render.sampler)},
                    {"russian_roulette_depth", s.render.russian_roulette_depth == kRouletteDepthAuto
                                                   ? Json("auto")
                                                   : Json(s.render.russian_roulette_depth)},
                    {"seed", s.render.seed}};
  const EnvironmentDesc& e = s.environment;
  if (e.type == EnvironmentType::Constant) {
    root["background"] = triple(e.radiance);
  } else {
    Json env = {{"type", to_string(e.type)}};
    if (e.type == EnvironmentType::Sky) {
      env["sun_direction"] = triple(e.sun_direction);
      env["turbidity"] = number(e.turbidity);
      env["sun"] = e.sun;
    } else {
      env["file"] = file_reference(e.file, e.resolved_file, destination_dir);
      env["rotation_deg"] = number(e.rotation_deg);
    }
    env["scale"] = number(e.scale);
    root["environment"] = std::move(env);
  }
  Json materials = Json::object();
  for (const MaterialDesc& m : s.materials) {
    Json j = {{"type", to_string(m.type)}};
    const MaterialType t = m.type;  // only the parameters its type takes (kMaterialParams)
    if (takes(t, MaterialParam::Metal) && m.metal != MetalPreset::None) {
      j["metal"] = to_string(m.metal);
    } else if (takes(t, MaterialParam::Metal) && m.complex_ior) {
      j["eta"] = triple(m.eta);
      j["k"] = triple(m.k);
    } else if (takes(t, MaterialParam::Albedo)) {
      j["albedo"] = triple(m.albedo);
      if (!m.albedo_texture.empty())
        j["albedo_texture"] = file_reference(m.albedo_texture, m.resolved_albedo_texture, destination_dir);
    }
    if (takes(t, MaterialParam::Ior)) j["ior"] = number(m.ior);
    if (takes(t, MaterialParam::Roughness)) j["roughness"] = number(m.roughness);
    if (takes(t, MaterialParam::G)) j["g"] = number(m.g);
    if (takes(t, MaterialParam::Metallic)) j["metallic"] = number(m.metallic);
    if (!(positive_zero(m.emission.x) && positive_zero(m.emission.y) && positive_zero(m.emission.z)))
      j["emission"] = triple(m.emission);
    if (m.two_sided) j["two_sided"] = true;
    materials[m.name] = std::move(j);
  }
  root["materials"] = std::move(materials);
  const auto material_name = [&](int m, const std::string& what) -> const std::string& {
    if (m < 0 || m >= static_cast<int>(s.materials.size()))
      throw std::invalid_argument("scene_to_json: " + what + ".material: no such material");
    return s.materials[static_cast<size_t>(m)].name;
  };
  // An object's one material (its shapes' and its instances'), or "" when they differ (a glTF model's triangles
  // keep the file's materials).
  const auto object_material = [&](size_t object) {
    const ObjectDesc& o = s.objects[object];
    int one = -1;
    bool same = true;
    const auto see = [&](int m) { same = same && (one < 0 || m == one), one = one < 0 ? m : one; };
    for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k) see(s.shapes[k].material);
    for (const InstanceDesc& in : s.instances)
      if (in.object == static_cast<int>(object))
        for (int m : in.materials) see(m);
    return same && one >= 0 ? material_name(one, "objects[" + std::to_string(object) + "]") : std::string();
  };
  Json shapes = Json::array();
  size_t next_object = 0;
  for (size_t i = 0; i < s.shapes.size() || next_object < s.objects.size();) {
    if (next_object < s.objects.size() && s.objects[next_object].first_shape <= i) {
      const ObjectDesc& o = s.objects[next_object];
      shapes.push_back(object_json(o, s.shapes, object_material(next_object), destination_dir));
      ++next_object;
      i = o.first_shape + o.shape_count;
      continue;
    }
    if (i >= s.shapes.size()) break;
    Json j = shape_json(s.shapes[i]);
    j["material"] = material_name(s.shapes[i].material, "shapes[" + std::to_string(i) + "]");
    shapes.push_back(std::move(j));
    ++i;
  }
  root["shapes"] = std::move(shapes);
  return root;
}

// Pretty printer: a container goes on one line when it fits in kWidth columns (a shape of the canonical scenes
// does), else one element per line.
constexpr size_t kWidth = 150;

std::string scalar(const Json& v) { return v.dump(-1, ' ', false, Json::error_handler_t::replace); }

std::string one_line(const Json& v) {
  if (v.is_array()) {
    std::string out = "[";
    for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + one_line(v[i]);
    return out + "]";
  }
  if (v.is_object()) {
    std::string out = "{";
    bool first = true;
    for (const auto& item : v.items()) {
      out += (first ? "" : ", ") + quoted(item.key()) + ": " + one_line(item.value());
      first = false;
    }
    return out + "}";
  }
  return scalar(v);
}

// `column` is where the value starts on its line (after the indentation and any "key": prefix).
void write(std::string& out, const Json& v, size_t indent, size_t column, bool force_break) {
  const bool container = v.is_array() || v.is_object();
  if (!container || v.empty() || !force_break) {
    std::string line = one_line(v);
    if (!container || v.empty() || column + line.size() <= kWidth) {
      out += line;
      return;
    }
  }
  const std::string pad(indent + 2, ' ');
  out += v.is_array() ? "[\n" : "{\n";
  size_t i = 0;
  for (const auto& item : v.items()) {
    out += pad;
    size_t col = pad.size();
    if (v.is_object()) {
      const std::string key = quoted(item.key()) + ": ";
      out += key;
      col += key.size();
    }
    write(out, item.value(), indent + 2, col, false);
    out += ++i < v.size() ? ",\n" : "\n";
  }
  out += std::string(indent, ' ') + (v.is_array() ? "]" : "}");
}

}  // namespace

// validate_scene names a shape by its index in SceneDesc::shapes, where a file's meshes and groups count many:
// the message names the file's element instead ("shapes[6].shapes[2]", the third shape of a group, or
// "shapes[6] (triangle 17 of bunny.obj)").
std::string in_file_terms(const SceneDesc& d, const std::string& message) {
  constexpr std::string_view kPrefix = "shapes[";
  if (d.objects.empty() || message.compare(0, kPrefix.size(), kPrefix) != 0) return message;
  const size_t close = message.find(']');
  if (close == std::string::npos) return message;
  size_t k = 0;
  const auto parsed = std::from_chars(message.data() + kPrefix.size(), message.data() + close, k);
  if (parsed.ec != std::errc() || parsed.ptr != message.data() + close) return message;
  size_t element_index = k;  // counting each object before k as one element
  std::string inner;
  for (const ObjectDesc& o : d.objects) {
    if (o.first_shape > k) break;
    if (k < o.first_shape + o.shape_count) {
      element_index -= k - o.first_shape;
      inner = o.kind == ObjectKind::Group ? ".shapes[" + std::to_string(k - o.first_shape) + "]"
                                          : " (triangle " + std::to_string(k - o.first_shape) + " of " + o.file + ")";
      break;
    }
    element_index -= o.shape_count - 1;
  }
  return "shapes[" + std::to_string(element_index) + "]" + inner + message.substr(close + 1);
}

// -------------------------------------------------------------------------------------------------------------------

SceneDesc parse_scene(const std::string& json_text, const std::string& source_name, const std::string& base_dir) {
  const auto where = [&](const PathError& e) {
    return source_name + ": " + (e.path.empty() ? "" : e.path + ": ") + e.reason;
  };
  if (const size_t nul = json_text.find('\0'); nul != std::string::npos) {
    const size_t line = 1 + static_cast<size_t>(std::count(json_text.begin(), json_text.begin() + nul, '\n'));
    throw SceneError(source_name + ": line " + std::to_string(line) + ": a NUL byte (this is not a JSON text file)");
  }
  Json root;
  StreamedShapes streamed;
  streamed.base_dir = base_dir;
  SceneSax sax(
      root, [&](const ShapeDesc& shape, std::string_view material, size_t index) { streamed.add(shape, material, index); },
      [&](const Json& element, size_t index) { streamed.add(element, index); });
  rapidjson::Reader reader;
  // A bounded stream: RapidJSON 1.1.0's UTF-8 validation steps past the terminating NUL of a StringStream when
  // the text ends inside a multi-byte sequence (a heap over-read found by fuzz_scene); MemoryStream stops at
  // the end.
  rapidjson::MemoryStream in(json_text.data(), json_text.size());
  constexpr unsigned kFlags =
      rapidjson::kParseIterativeFlag | rapidjson::kParseNumbersAsStringsFlag | rapidjson::kParseValidateEncodingFlag;
  const rapidjson::ParseResult result = reader.Parse<kFlags>(in, sax);
  if (sax.error()) throw SceneError(where(*sax.error()));
  if (result.Code() == rapidjson::kParseErrorNumberTooBig)  // e.g. 1e999: named by its path, like other values
    throw SceneError(where({sax.path(), "must be finite (number too large for a double)"}));
  if (result.IsError()) throw SceneError(source_name + ": " + syntax_message(result.Code(), result.Offset(), json_text));
  SceneDesc desc;
  try {
    desc = read_scene(root, base_dir, streamed);
  } catch (const PathError& e) {
    throw SceneError(where(e));
  }
  if (const std::string err = validate_scene(desc); !err.empty())
    throw SceneError(source_name + ": " + in_file_terms(desc, err));
  for (const std::string& w : streamed.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return desc;
}

SceneDesc load_scene_file(const std::string& path) {
  std::string text;
  try {
    text = read_file_limited(path, kMaxSceneFileBytes);
  } catch (const FileError& e) {
    throw SceneError(e.what());
  }
  return parse_scene(text, path, path == "-" ? std::string() : std::filesystem::path(path).parent_path().string());
}

std::string scene_to_json(const SceneDesc& scene, const std::optional<std::string>& destination_dir) {
  // The top level and the material and shape lists always get one entry per line; the rest fits where it can.
  const Json root = to_json(scene, destination_dir);
  std::string out = "{\n";
  size_t i = 0;
  for (const auto& item : root.items()) {
    const std::string key = "  " + quoted(item.key()) + ": ";
    out += key;
    write(out, item.value(), 2, key.size(), item.key() == "materials" || item.key() == "shapes");
    out += ++i < root.size() ? ",\n" : "\n";
  }
  return out + "}\n";
}

SceneDesc load_scene(const std::string& spec) {
  if (is_model_file(spec)) return studio_scene(spec);  // a model alone: placed in a studio (scene/studio.h)
  const bool is_file = spec.find('/') != std::string::npos ||
                       (spec.size() >= 5 && spec.compare(spec.size() - 5, 5, ".json") == 0);
  if (is_file) return load_scene_file(spec);
  if (const auto text = builtin_scene_json(spec)) return parse_scene(std::string(*text), "builtin:" + spec);
  std::string names;
  for (const std::string& n : builtin_scene_names()) names += (names.empty() ? "" : ", ") + n;
  throw SceneError(spec + ": unknown built-in scene (built-in scenes: " + names +
                   "; a scene file path must end in .json or contain '/', a model file in .obj, .gltf or .glb)");
}

}  // namespace pt
