// Image files the viewer writes: names that never overwrite earlier files, and PNG from 8-bit display pixels.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace pt {

// DIR/BASE-NNNN (no extension) with the smallest NNNN ≥ 1 such that no file DIR/BASE-NNNN.* among `extensions`
// exists, so a PNG and its PFM share a number and nothing earlier is overwritten.
std::string unique_output_stem(const std::string& dir, const std::string& base, const std::vector<std::string>& extensions);

// Writes RGBA8 pixels (top row first) as an RGB PNG, atomically (temp file + rename). Throws ImageError.
void write_png_rgba8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba);

// The short name of a scene spec: a built-in name as is, a file's stem otherwise.
std::string scene_short_name(const std::string& spec);

}  // namespace pt
