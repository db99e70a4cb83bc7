// A headless OpenGL 3.3 core context (Mesa's OSMesa, software rasteriser) for the GL tests. No display needed.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace pt::test {

class OsMesaContext {
 public:
  // Creates a core-profile 3.3 context rendering into a width × height RGBA8 buffer and makes it current.
  // Throws std::runtime_error if OSMesa cannot.
  OsMesaContext(int width, int height);
  ~OsMesaContext();
  OsMesaContext(const OsMesaContext&) = delete;
  OsMesaContext& operator=(const OsMesaContext&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  std::string version() const;  // GL_VERSION
  // The default framebuffer after glFinish, RGBA8, top row first.
  std::vector<uint8_t> read_pixels() const;
  void clear(float r, float g, float b) const;

 private:
  void* ctx_ = nullptr;
  int width_, height_;
  std::vector<uint8_t> buffer_;
};

}  // namespace pt::test
