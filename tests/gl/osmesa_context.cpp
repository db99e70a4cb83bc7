#include "osmesa_context.h"

#define GL_GLEXT_PROTOTYPES 1  // glBindFramebuffer (GL 3.0) from glext.h
#include <GL/osmesa.h>

#include <cstring>
#include <stdexcept>

namespace pt::test {

OsMesaContext::OsMesaContext(int width, int height) : width_(width), height_(height), buffer_(4ull * width * height) {
  const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                         OSMESA_PROFILE, OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, 3,
                         OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
  OSMesaContext ctx = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!ctx) throw std::runtime_error("OSMesaCreateContextAttribs failed (core profile 3.3)");
  if (!OSMesaMakeCurrent(ctx, buffer_.data(), GL_UNSIGNED_BYTE, width, height)) {
    OSMesaDestroyContext(ctx);
    throw std::runtime_error("OSMesaMakeCurrent failed");
  }
  ctx_ = ctx;
}

OsMesaContext::~OsMesaContext() { OSMesaDestroyContext(static_cast<OSMesaContext>(ctx_)); }

std::string OsMesaContext::version() const {
  const auto* v = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  return v ? v : "";
}

std::vector<uint8_t> OsMesaContext::read_pixels() const {
  std::vector<uint8_t> px(4ull * width_ * height_);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  std::vector<uint8_t> top_first(px.size());
  const size_t row = 4ull * width_;
  for (int y = 0; y < height_; ++y) std::memcpy(&top_first[row * y], &px[row * (height_ - 1 - y)], row);
  return top_first;
}

void OsMesaContext::clear(float r, float g, float b) const {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, width_, height_);
  glClearColor(r, g, b, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
}

}  // namespace pt::test
