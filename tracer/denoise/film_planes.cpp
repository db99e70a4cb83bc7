#include "denoise/denoiser.h"

#include <stdexcept>

#include "film/film.h"

namespace pt {

void check_denoise_input(const DenoiseInput& in) {
  const size_t n = static_cast<size_t>(in.width) * static_cast<size_t>(in.height);
  if (in.width <= 0 || in.height <= 0) throw std::invalid_argument("denoise: empty image");
  for (const auto* p : {in.color, in.variance, in.albedo, in.normal})
    if (!p || p->size() != 3 * n) throw std::invalid_argument("denoise: a 3-channel input is missing or mis-sized");
  if (!in.depth || in.depth->size() != n) throw std::invalid_argument("denoise: depth is missing or mis-sized");
  if (in.emission && in.emission->size() != 3 * n) throw std::invalid_argument("denoise: emission is mis-sized");
}

void FilmPlanes::copy_from(const Film& film, bool with_variance) {
  width = film.width();
  height = film.height();
  film.mean_image(color);
  if (with_variance) film.variance_image(variance);
  else variance.resize(color.size());
  film.albedo_image(albedo);
  film.normal_image(normal);
  film.depth_image(depth);
  film.emission_image(emission);
}

std::vector<float> denoise_film(const Film& film, const DenoiseSettings& settings, ThreadPool& pool) {
  FilmPlanes planes;
  planes.copy_from(film);
  return denoise(planes.input(), settings, pool);
}

std::vector<float> denoise_film(const Film& film, DenoiseMethod method, ThreadPool& pool) {
  if (method == DenoiseMethod::Atrous) return denoise_film(film, DenoiseSettings{}, pool);
  FilmPlanes planes;
  planes.copy_from(film);
  return denoise_regression(planes.input(), RegressionSettings{}, pool);
}

}  // namespace pt
