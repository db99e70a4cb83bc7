#version 330 core
// The viewer's display transform. Colour mode mirrors tracer/tonemap.h exactly (exposure -> tone map -> sRGB
// encoding, written to a plain 8-bit framebuffer, i.e. rounded to nearest like to_srgb8); the diagnostic modes
// mirror app/display_transform.h. The GL tests compare both with the CPU definitions within 1/255.
// PALETTE_SIZE and VARIANT are defined by the program that compiles this source (gl_presenter.cpp): the size of
// kFalseColour, and which view this compiled program draws (GlPresenter::Variant's order, below). Each variant reads
// only the textures its view needs: under a software GL such as llvmpipe each texture read over a 512² image
// costs 1–2 ms, and neither a select nor a branch on a uniform spares the reads a pixel does not use
// (docs/viewer.md, "The display pass").
#define COLOUR_IMAGE 0     // the colour view of the film's mean
#define COLOUR_DENOISED 1  // the colour view of the denoised image
#define COLOUR_MIXED 2     // the colour view with a split (denoised, or an A/B snapshot)
#define RELATIVE_ERROR 3
#define DIFFERENCE 4       // to the snapshot
#define SAMPLE_COUNT 5

in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_image;        // rgb: mean radiance; a: relative standard error of the mean
uniform sampler2D u_count;        // r: samples per pixel
uniform sampler2D u_denoised;     // rgb: the denoised mean (when u_denoised_from_u <= 1)
uniform float u_denoised_from_u;  // the colour view shows u_denoised where uv.x >= this (display_transform.h)
uniform sampler2D u_snapshot;     // rgb: a kept snapshot's mean (A/B compare)
uniform float u_snapshot_until_u; // the colour view shows u_snapshot where uv.x < this
uniform float u_exposure_scale;   // 2^EV, computed on the CPU with std::exp2 as tonemap.h does
uniform int u_tone_map;           // 0 clamp, 1 Reinhard, 2 ACES fitted (pt::ToneMap order)
uniform vec2 u_error_log10_range; // log10 relative errors mapped to the ends of the colour map
uniform float u_count_max;
uniform vec3 u_palette[PALETTE_SIZE];  // sRGB-encoded stops, evenly spaced

// Narkowicz 2015 ACES fit, as pt::aces_fitted.
float aces_fitted(float x) {
  const float a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14;
  return clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0);
}

vec3 tone_map(vec3 c) {
  c *= u_exposure_scale;
  if (u_tone_map == 0) return clamp(c, 0.0, 1.0);
  if (u_tone_map == 1) return c / (vec3(1.0) + c);
  return vec3(aces_fitted(c.r), aces_fitted(c.g), aces_fitted(c.b));
}

// IEC 61966-2-1 sRGB encoding, as pt::srgb_encode.
float srgb_encode(float x) {
  x = clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

vec3 false_colour(float t) {
  t = clamp(t, 0.0, 1.0) * float(PALETTE_SIZE - 1);
  int i = min(int(t), PALETTE_SIZE - 2);
  return mix(u_palette[i], u_palette[i + 1], t - float(i));
}

vec4 colour(vec3 mean) {
  vec3 c = tone_map(mean);
  return vec4(srgb_encode(c.r), srgb_encode(c.g), srgb_encode(c.b), 1.0);
}

float error_coordinate(float e) {
  float l = log2(max(e, 1e-30)) * 0.30102999566;
  return (l - u_error_log10_range.x) / (u_error_log10_range.y - u_error_log10_range.x);
}

void main() {
  vec2 uv = vec2(v_uv.x, 1.0 - v_uv.y);  // the film's first row is the top of the image
#if VARIANT == COLOUR_IMAGE
  frag_colour = colour(texture(u_image, uv).rgb);
#elif VARIANT == COLOUR_DENOISED
  frag_colour = colour(texture(u_denoised, uv).rgb);
#elif VARIANT == COLOUR_MIXED
  frag_colour = colour(uv.x < u_snapshot_until_u ? texture(u_snapshot, uv).rgb
                       : uv.x >= u_denoised_from_u ? texture(u_denoised, uv).rgb : texture(u_image, uv).rgb);
#elif VARIANT == RELATIVE_ERROR
  frag_colour = vec4(false_colour(error_coordinate(texture(u_image, uv).a)), 1.0);
#elif VARIANT == DIFFERENCE  // display_transform.h relative_difference
  vec3 b = texture(u_snapshot, uv).rgb, d = texture(u_image, uv).rgb - b;
  frag_colour = vec4(false_colour(error_coordinate(sqrt(dot(d * d / (b * b + vec3(0.01)), vec3(1.0)) * (1.0 / 3.0)))), 1.0);
#else
  frag_colour = vec4(false_colour(texture(u_count, uv).r / max(u_count_max, 1.0)), 1.0);
#endif
}
