#include "viewer/gl_presenter.h"

#include <cstring>
#include <string>

#include "viewer/gl_api.h"
#include "render/render_session.h"
#include "viewer/shader_sources.h"

namespace pt {

namespace {

// present.frag sizes its palette array with PALETTE_SIZE and draws the view VARIANT; the defines go right after
// the #version line.
std::string with_defines(std::string_view src, int variant) {
  const size_t eol = src.find('\n');
  std::string out(src.substr(0, eol + 1));
  out += "#define PALETTE_SIZE " + std::to_string(kFalseColour.size()) + "\n";
  out += "#define VARIANT " + std::to_string(variant) + "\n";
  out += src.substr(eol + 1);
  return out;
}

GLuint compile(GLenum type, const std::string& src, const char* name) {
  const GLuint s = glCreateShader(type);
  const char* text = src.c_str();
  glShaderSource(s, 1, &text, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw GlError(std::string("cannot compile ") + name + ": " + log);
  }
  return s;
}

GLuint make_texture() {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  // The shader reads texels 1:1 (the cache has the image's size), so nearest is exact: no blending ever.
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

}  // namespace

GlPresenter::GlPresenter() {
  vertex_shader_ = compile(GL_VERTEX_SHADER, std::string(shader_source("fullscreen")), "shaders/fullscreen.vert");
  try {
    program(Variant::ColourImage);  // the default view: a shader that does not compile fails here, not mid-run
  } catch (...) {
    glDeleteShader(vertex_shader_);
    throw;
  }
  glGenVertexArrays(1, &vao_);  // core profile draws need a bound VAO, even an empty one
  image_tex_ = make_texture();
  count_tex_ = make_texture();
  denoised_tex_ = make_texture();
  snapshot_tex_ = make_texture();
  display_tex_ = make_texture();
  glBindTexture(GL_TEXTURE_2D, 0);
  glGenFramebuffers(1, &display_fbo_);
}

const GlPresenter::Program& GlPresenter::program(Variant v) {
  Program& p = programs_[static_cast<int>(v)];
  if (p.id != 0) return p;
  const GLuint fs =
      compile(GL_FRAGMENT_SHADER, with_defines(shader_source("present"), static_cast<int>(v)), "shaders/present.frag");
  const GLuint id = glCreateProgram();
  glAttachShader(id, vertex_shader_);
  glAttachShader(id, fs);
  glLinkProgram(id);
  glDetachShader(id, vertex_shader_);  // kept for the other variants
  glDeleteShader(fs);                  // flagged; freed with the program
  GLint ok = 0;
  glGetProgramiv(id, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetProgramInfoLog(id, sizeof log, nullptr, log);
    glDeleteProgram(id);
    throw GlError(std::string("cannot link the display shaders: ") + log);
  }
  p.id = id;
  // Uniforms a variant does not use are compiled out: their location is −1, which glUniform ignores.
  p.exposure = glGetUniformLocation(id, "u_exposure_scale");
  p.tone_map = glGetUniformLocation(id, "u_tone_map");
  p.error_range = glGetUniformLocation(id, "u_error_log10_range");
  p.count_max = glGetUniformLocation(id, "u_count_max");
  p.denoised_from_u = glGetUniformLocation(id, "u_denoised_from_u");
  p.snapshot_until_u = glGetUniformLocation(id, "u_snapshot_until_u");
  // Constant uniforms are set once.
  GLint previous = 0;
  glGetIntegerv(GL_CURRENT_PROGRAM, &previous);
  glUseProgram(id);
  glUniform1i(glGetUniformLocation(id, "u_image"), 0);
  glUniform1i(glGetUniformLocation(id, "u_count"), 1);
  glUniform1i(glGetUniformLocation(id, "u_denoised"), 2);
  glUniform1i(glGetUniformLocation(id, "u_snapshot"), 3);
  float palette[3 * kFalseColour.size()];
  for (size_t i = 0; i < kFalseColour.size(); ++i)
    for (int c = 0; c < 3; ++c) palette[3 * i + c] = static_cast<float>(kFalseColour[i][c]) / 255.f;
  glUniform3fv(glGetUniformLocation(id, "u_palette"), static_cast<GLsizei>(kFalseColour.size()), palette);
  glUseProgram(static_cast<GLuint>(previous));
  return p;
}

GlPresenter::~GlPresenter() {
  glDeleteFramebuffers(1, &display_fbo_);
  glDeleteTextures(1, &display_tex_);
  glDeleteTextures(1, &image_tex_);
  glDeleteTextures(1, &count_tex_);
  glDeleteTextures(1, &denoised_tex_);
  glDeleteTextures(1, &snapshot_tex_);
  glDeleteVertexArrays(1, &vao_);
  for (const Program& p : programs_)
    if (p.id != 0) glDeleteProgram(p.id);
  glDeleteShader(vertex_shader_);
}

void GlPresenter::upload(const DisplayFrame& f) {
  if (f.width <= 0 || f.height <= 0 || f.rgba.size() < 4ull * f.width * f.height ||
      f.count.size() < 1ull * f.width * f.height)
    return;
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  const bool resize = f.width != width_ || f.height != height_;
  glBindTexture(GL_TEXTURE_2D, image_tex_);
  if (resize) glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, f.width, f.height, 0, GL_RGBA, GL_FLOAT, f.rgba.data());
  else glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, f.width, f.height, GL_RGBA, GL_FLOAT, f.rgba.data());
  glBindTexture(GL_TEXTURE_2D, count_tex_);
  if (resize) glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, f.width, f.height, 0, GL_RED, GL_FLOAT, f.count.data());
  else glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, f.width, f.height, GL_RED, GL_FLOAT, f.count.data());
  has_denoised_ = f.denoised.size() >= 3ull * f.width * f.height;
  if (has_denoised_) {
    glBindTexture(GL_TEXTURE_2D, denoised_tex_);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);  // RGB rows need not be 4-byte multiples
    if (resize || !denoised_allocated_)
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, f.width, f.height, 0, GL_RGB, GL_FLOAT, f.denoised.data());
    else glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, f.width, f.height, GL_RGB, GL_FLOAT, f.denoised.data());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    denoised_allocated_ = true;
  }
  if (resize) {  // the display image follows the film's size (and so does the denoised one, when it comes)
    if (!has_denoised_) denoised_allocated_ = false;
    glBindTexture(GL_TEXTURE_2D, display_tex_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, f.width, f.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    GLint previous_fbo = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, display_fbo_);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, display_tex_, 0);
    const bool complete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous_fbo));
    if (!complete) throw GlError("display framebuffer incomplete");
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  width_ = f.width;
  height_ = f.height;
  preview_ = f.preview;
  max_count_ = f.max_count;
  display_valid_ = false;
}

void GlPresenter::upload_snapshot(const DisplayFrame& f) {
  if (f.width <= 0 || f.height <= 0 || f.rgba.size() < 4ull * f.width * f.height) return;
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glBindTexture(GL_TEXTURE_2D, snapshot_tex_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, f.width, f.height, 0, GL_RGBA, GL_FLOAT, f.rgba.data());
  glBindTexture(GL_TEXTURE_2D, 0);
  snapshot_width_ = f.width;
  snapshot_height_ = f.height;
  display_valid_ = false;
}

namespace {

bool same(const PresentSettings& a, const PresentSettings& b) {
  return a.display.exposure_ev == b.display.exposure_ev && a.display.tone_map == b.display.tone_map &&
         a.mode == b.mode && a.error_log10_min == b.error_log10_min && a.error_log10_max == b.error_log10_max &&
         a.denoise == b.denoise && a.denoise_view == b.denoise_view && a.snapshot_view == b.snapshot_view;
}

}  // namespace

void GlPresenter::update_display(const PresentSettings& s) {
  if (display_valid_ && same(s, display_settings_)) return;
  GLint previous_fbo = 0, viewport[4];
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_fbo);
  glGetIntegerv(GL_VIEWPORT, viewport);
  glBindFramebuffer(GL_FRAMEBUFFER, display_fbo_);
  glViewport(0, 0, width_, height_);
  glDisable(GL_BLEND);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_FRAMEBUFFER_SRGB);  // the shader encodes sRGB itself, as tonemap.h does
  // Without a snapshot of this image's size, the A/B views fall back to the live colour view.
  const bool snapshot = has_snapshot();
  const ViewMode mode = !snapshot && s.mode == ViewMode::Difference ? ViewMode::Colour : s.mode;
  const float snapshot_u = snapshot ? snapshot_until_u(s.snapshot_view) : -1.f;  // u < this: the snapshot
  const float denoised_u = has_denoised_ && s.denoise ? denoised_from_u(s.denoise_view) : 2.f;  // u ≥ this
  Variant v = Variant::SampleCount;
  if (mode == ViewMode::Colour)
    v = snapshot_u > 0.f ? Variant::ColourMixed
        : denoised_u <= 0.f ? Variant::ColourDenoised
        : denoised_u > 1.f  ? Variant::ColourImage
                            : Variant::ColourMixed;
  else if (mode == ViewMode::RelativeError) v = Variant::RelativeError;
  else if (mode == ViewMode::Difference) v = Variant::Difference;
  const Program& p = program(v);
  glUseProgram(p.id);
  glUniform1f(p.snapshot_until_u, snapshot_u);
  glUniform1f(p.exposure, std::exp2(s.display.exposure_ev));
  glUniform1i(p.tone_map, static_cast<int>(s.display.tone_map));
  glUniform2f(p.error_range, s.error_log10_min, s.error_log10_max);
  glUniform1f(p.count_max, max_count_);
  glUniform1f(p.denoised_from_u, denoised_u);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, image_tex_);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, count_tex_);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_2D, denoised_tex_);
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, snapshot_tex_);
  glBindVertexArray(vao_);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glActiveTexture(GL_TEXTURE0);
  glUseProgram(0);
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous_fbo));
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
  display_settings_ = s;
  display_valid_ = true;
}

void GlPresenter::draw(int x, int y, int w, int h, const PresentSettings& s) {
  if (!has_image() || w <= 0 || h <= 0) return;
  update_display(s);
  // Scaling: a full-resolution image shown at 1:1 or larger copies nearest pixels (each screen pixel is exactly
  // one display pixel); a preview, or an image shown smaller, is filtered bilinearly.
  const bool exact = !preview_ && w >= width_ && h >= height_;
  GLint previous_read = 0;
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &previous_read);
  glDisable(GL_SCISSOR_TEST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, display_fbo_);
  glBlitFramebuffer(0, 0, width_, height_, x, y, x + w, y + h, GL_COLOR_BUFFER_BIT, exact ? GL_NEAREST : GL_LINEAR);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(previous_read));
}

void GlPresenter::read_image(const PresentSettings& s, std::vector<uint8_t>& rgba) {
  rgba.assign(4ull * width_ * height_, 0);
  if (!has_image()) return;
  update_display(s);
  GLint previous_read = 0;
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &previous_read);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, display_fbo_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(previous_read));
  // GL's first row is the bottom one: flip to top-first.
  const size_t row = 4ull * width_;
  std::vector<uint8_t> tmp(row);
  for (int y = 0; y < height_ / 2; ++y) {
    uint8_t* a = &rgba[row * y];
    uint8_t* b = &rgba[row * (height_ - 1 - y)];
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
}

}  // namespace pt
