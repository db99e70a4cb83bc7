// Shows a DisplayFrame with OpenGL 3.3 core: float textures (mean + relative error, sample count) turned into
// display pixels by shaders/present.frag (fullscreen triangle), at the image's own resolution, into an RGBA8
// "display image" that is then blitted (scaled) to the screen. The shader runs only when the frame or the
// display settings change, not every UI frame: that matters under software GL (llvmpipe on Xvfb, VMs, remote
// X), where it is the main cost of a frame. Works with whatever context is current (a GLFW window, an OSMesa
// buffer) and knows nothing about windows. Construct, use and destroy it with its context current, on the thread
// that owns the context (render threads never get here).
#pragma once
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "viewer/display_transform.h"

namespace pt {

struct DisplayFrame;

struct GlError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class GlPresenter {
 public:
  GlPresenter();  // compiles and links the colour view's shaders; throws GlError with the driver's log
  ~GlPresenter();
  GlPresenter(const GlPresenter&) = delete;
  GlPresenter& operator=(const GlPresenter&) = delete;

  // Copies the frame into the textures, reallocated only when the size changes.
  void upload(const DisplayFrame& frame);
  bool has_image() const { return width_ > 0; }
  // A/B compare: keeps this frame's mean as the snapshot. It is shown (SnapshotView, ViewMode::Difference) only
  // while the image has the snapshot's size; otherwise the colour view shows the live image.
  void upload_snapshot(const DisplayFrame& frame);
  bool has_snapshot() const { return snapshot_width_ > 0 && snapshot_width_ == width_ && snapshot_height_ == height_; }
  int width() const { return width_; }
  int height() const { return height_; }

  // Draws the image into the rectangle (x, y, w, h) of the current draw framebuffer (GL convention: y from the
  // bottom). A full-resolution image at 1:1 or larger is copied pixel for pixel (nearest); previews and images
  // shown smaller are scaled bilinearly.
  void draw(int x, int y, int w, int h, const PresentSettings& settings);

  // The display image at the image's own resolution as RGBA8, top row first: what draw() shows, in any view
  // mode, without scaling. `rgba` is resized to 4·width·height.
  void read_image(const PresentSettings& settings, std::vector<uint8_t>& rgba);

 private:
  // The views present.frag is compiled for, one program each (its VARIANT, in this order), so that a view reads
  // only the textures it shows.
  enum class Variant { ColourImage, ColourDenoised, ColourMixed, RelativeError, Difference, SampleCount };
  static constexpr int kVariants = static_cast<int>(Variant::SampleCount) + 1;
  struct Program {
    unsigned id = 0;
    int exposure = -1, tone_map = -1, error_range = -1, count_max = -1, denoised_from_u = -1, snapshot_until_u = -1;
  };
  void update_display(const PresentSettings& settings);  // runs the shader if the frame or settings changed
  const Program& program(Variant v);                     // compiled and linked on first use

  Program programs_[kVariants];
  unsigned vertex_shader_ = 0;
  unsigned vao_ = 0, image_tex_ = 0, count_tex_ = 0, denoised_tex_ = 0;
  bool has_denoised_ = false;  // the last frame uploaded had a denoised image
  bool denoised_allocated_ = false;  // denoised_tex_ has the image's size
  unsigned display_tex_ = 0, display_fbo_ = 0;  // the shader's output, RGBA8, the image's size
  bool display_valid_ = false;
  PresentSettings display_settings_;
  int width_ = 0, height_ = 0;
  bool preview_ = false;
  float max_count_ = 0;
  unsigned snapshot_tex_ = 0;
  int snapshot_width_ = 0, snapshot_height_ = 0;
};

}  // namespace pt
